//! Bootstrap over trajectories: how much the identified coefficients and
//! vector field move when the experiment is repeated.
//!
//! Samples of one trajectory are correlated, so the unit of resampling is a
//! whole trajectory (or any group the caller chooses): each replicate draws
//! as many groups as there are, with replacement, and identifies on their
//! union. Percentiles of the replicates give the intervals. They measure
//! how the fit varies between draws, not a bias that every draw shares
//! (noisy states in the weak form or in derivative estimates pull every
//! fit the same way), and with few groups they are narrower than their
//! level: the spread of a resample understates the experiment's by about
//! (G − 1)/G in variance for G groups. Replicate b
//! draws from ChaCha8 seeded with (seed, b), and replicates run in parallel
//! on rayon's pool, so the result is the same for a seed on any number of
//! threads.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::data::IdentificationData;
use crate::error::{invalid, Error, Result};
use crate::identify::{identify, IdentifyConfig, IdentifyWarning};
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// Options of [`bootstrap`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BootstrapOptions {
    /// Number of replicates, 2 to 100 000. Default 50.
    pub replicates: usize,
    /// Coverage of the intervals, in (0, 1). Default 0.95.
    pub level: f64,
    /// Seed of the resampling. Default 0.
    pub seed: u64,
}

impl Default for BootstrapOptions {
    fn default() -> Self {
        Self {
            replicates: 50,
            level: 0.95,
            seed: 0,
        }
    }
}

/// A percentile interval and the median.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    /// Lower end.
    pub lower: f64,
    /// Median of the replicates.
    pub median: f64,
    /// Upper end.
    pub upper: f64,
}

impl Interval {
    /// Whether `value` lies in [lower, upper].
    pub fn contains(&self, value: f64) -> bool {
        (self.lower..=self.upper).contains(&value)
    }
}

/// The result of [`bootstrap`].
#[derive(Debug, Clone)]
pub struct Bootstrap<S: MetriplecticSystem> {
    /// The model of every replicate whose identification succeeded, in
    /// replicate order.
    pub replicates: Vec<Model<S>>,
    /// Each replicate's [`Identification::warnings`](crate::Identification::warnings),
    /// in the order of `replicates`: intervals from replicates whose data
    /// cannot determine the model are not uncertainties of the data's model.
    pub warnings: Vec<Vec<IdentifyWarning>>,
    /// Replicates whose identification returned an error.
    pub failed: usize,
    /// The first such error, in words (`None` if none failed): replicates
    /// that fail for a reason tied to their draw (a batch larger than the
    /// groups drawn) bias the intervals towards the draws that succeeded.
    pub first_failure: Option<String>,
    /// Interval coverage.
    pub level: f64,
    /// Percentile interval of every entropy coefficient.
    pub entropy: Vec<Interval>,
    /// Percentile interval of every metric coefficient.
    pub metric: Vec<Interval>,
}

impl<S: MetriplecticSystem> Bootstrap<S> {
    /// The vector field's uncertainty band at `x`: the percentile interval
    /// of each component of f(x) over the replicates. Errors on a state of
    /// the wrong length or a field that overflows.
    pub fn field_band(&self, x: &[f64]) -> Result<Vec<Interval>> {
        let n = S::DIM;
        let mut fields = Vec::with_capacity(self.replicates.len() * n);
        let mut field = vec![0.0; n];
        for model in &self.replicates {
            model.vector_field(x, &mut field)?;
            fields.extend_from_slice(&field);
        }
        Ok(intervals(&fields, n, self.level))
    }
}

/// Most replicates a bootstrap runs: each is a whole identification, and
/// the results are collected before the intervals are formed.
const MAX_REPLICATES: usize = 100_000;

/// Identifies `S` on `groups.len()` groups drawn with replacement from
/// `groups` (e.g. one dataset per trajectory), `options.replicates` times,
/// and returns percentile intervals of the coefficients.
///
/// Pass the full-data fit as `config.initial_entropy` / `initial_metric` to
/// start every replicate near it, and a gauge when the data fix K only up to
/// scale (else the intervals measure the arbitrary scale). Errors on fewer
/// than two groups, invalid options, or if every replicate fails.
/// `config.checkpoint` is ignored: the replicates run in parallel and must
/// not replace the checkpoint of the user's own run.
pub fn bootstrap<S: MetriplecticSystem, D: IdentificationData>(
    groups: &[D],
    config: &IdentifyConfig,
    options: &BootstrapOptions,
) -> Result<Bootstrap<S>> {
    if groups.len() < 2 {
        return Err(invalid(
            "bootstrap groups",
            format!("{} given; resampling needs at least 2", groups.len()),
        ));
    }
    if !(2..=MAX_REPLICATES).contains(&options.replicates) {
        return Err(invalid(
            "bootstrap replicates",
            format!(
                "{} requested; intervals need at least 2, and at most {MAX_REPLICATES} are run \
                 (each is a whole identification)",
                options.replicates
            ),
        ));
    }
    if !(options.level > 0.0 && options.level < 1.0) {
        return Err(invalid(
            "bootstrap level",
            format!("{} is not in (0, 1)", options.level),
        ));
    }
    // Every group before any replicate: a bad one would fail only the
    // replicates that draw it, and the rest would give intervals
    // conditioned on never drawing it.
    for (index, group) in groups.iter().enumerate() {
        crate::data::check_dataset::<S>(group).map_err(|error| {
            invalid(
                "bootstrap group",
                format!("group {index} of {}: {error}", groups.len()),
            )
        })?;
    }
    let config = &IdentifyConfig {
        checkpoint: None,
        ..config.clone()
    };
    let results: Vec<Result<(Model<S>, Vec<IdentifyWarning>)>> = (0..options.replicates)
        .into_par_iter()
        .map(|b| {
            let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
            rng.set_stream(b as u64);
            let drawn: Vec<&D> = (0..groups.len())
                .map(|_| &groups[rng.random_range(0..groups.len())])
                .collect();
            let data = D::concat(&drawn)?;
            let fit = identify::<S>(&data, config)?;
            Ok((fit.model, fit.warnings))
        })
        .collect();
    let mut replicates = Vec::with_capacity(results.len());
    let mut warnings = Vec::with_capacity(results.len());
    let mut first_error: Option<Error> = None;
    for result in results {
        match result {
            Ok((model, replicate_warnings)) => {
                replicates.push(model);
                warnings.push(replicate_warnings);
            }
            Err(err) => {
                first_error.get_or_insert(err);
            }
        }
    }
    let failed = options.replicates - replicates.len();
    if replicates.len() < 2 {
        return Err(first_error
            .unwrap_or_else(|| invalid("bootstrap", "fewer than two replicates succeeded")));
    }
    let gather = |get: fn(&Model<S>) -> &[f64]| {
        let width = get(&replicates[0]).len();
        let values: Vec<f64> = replicates
            .iter()
            .flat_map(|m| get(m).iter().copied())
            .collect();
        intervals(&values, width, options.level)
    };
    let entropy = gather(Model::entropy_coefficients);
    let metric = gather(Model::metric_coefficients);
    Ok(Bootstrap {
        replicates,
        warnings,
        failed,
        first_failure: first_error.map(|error| error.to_string()),
        level: options.level,
        entropy,
        metric,
    })
}

/// Percentile intervals of each of `width` columns of the row-major `values`.
fn intervals(values: &[f64], width: usize, level: f64) -> Vec<Interval> {
    let rows = values.len() / width.max(1);
    (0..width)
        .map(|c| {
            let mut column: Vec<f64> = (0..rows).map(|r| values[r * width + c]).collect();
            column.sort_by(f64::total_cmp);
            let tail = (1.0 - level) / 2.0;
            Interval {
                lower: quantile(&column, tail),
                median: quantile(&column, 0.5),
                upper: quantile(&column, 1.0 - tail),
            }
        })
        .collect()
}

/// The q-quantile of sorted values, interpolating linearly between ranks.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    let position = q * (sorted.len() - 1) as f64;
    let (below, fraction) = (position.floor() as usize, position.fract());
    match sorted.get(below + 1) {
        Some(next) => sorted[below] + fraction * (next - sorted[below]),
        None => sorted[below],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentile_intervals_interpolate_between_ranks() {
        // Two columns: 0..=10 and their negatives, interleaved row-major.
        let values: Vec<f64> = (0..=10)
            .flat_map(|v| [f64::from(v), -f64::from(v)])
            .collect();
        let found = intervals(&values, 2, 0.9);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        let expected = [(0.5, 5.0, 9.5), (-9.5, -5.0, -0.5)];
        for (interval, (lower, median, upper)) in found.iter().zip(expected) {
            assert!(
                close(interval.lower, lower)
                    && close(interval.median, median)
                    && close(interval.upper, upper),
                "{interval:?}"
            );
        }
        assert!(found[0].contains(9.4) && !found[0].contains(9.6));
        assert_eq!(quantile(&[3.0], 0.975), 3.0);
    }
}
