//! The cost of a region certificate: the metric search and the joint step of
//! one system declared with and without `region ball(radius = 3)`.
//!
//! `DragDuffing` (entropy degree 4, metric degree 2) carries the region; the
//! twin declared here has the same state, Poisson tensor, Hamiltonian and
//! degrees and no region, so its certificate is the facially reduced global
//! one (K constant). Both solve the same 1000 exact samples of
//! `DragDuffing` from its reference entropy and the identity metric.
//!
//! `cargo bench --bench region` runs criterion (10 samples) and then prints
//! the with/without ratios measured by interleaved timing in the same
//! process, as a Markdown table for BENCHMARKS.md. `-- --quick` shortens
//! both.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::Criterion;
use metriplectic::systems::{reference_samples, DragDuffing};
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{joint_step, metric_search, SearchOptions};
use rand::Rng;

metriplectic! {
    /// `DragDuffing` without a region: the same program with the global
    /// certificate, whose facial reduction keeps K constant.
    pub struct DragDuffingWithoutRegion;
    state (x, v);
    poisson = [[0, -1], [1, 0]];
    hamiltonian = 0.5 * v^2 + 0.25 * x^4 - 0.5 * x^2;
    entropy degree 4;
    metric degree 2;
}

/// One system's two region-sensitive solves, ready to run.
struct Case<S: MetriplecticSystem> {
    data: Dataset,
    model: Model<S>,
    options: SearchOptions,
}

impl<S: MetriplecticSystem> Case<S> {
    fn new(data: &Dataset, entropy: &[f64]) -> Self {
        Self {
            data: data.clone(),
            model: Model::<S>::with_identity_metric(entropy.to_vec())
                .expect("the reference entropy is valid"),
            options: SearchOptions::default(),
        }
    }

    fn metric_search(&self) -> f64 {
        let search =
            metric_search::<S>(&self.data, self.model.entropy_coefficients(), &self.options)
                .expect("the metric search runs");
        assert!(
            search.report.status.is_usable(),
            "{:?}",
            search.report.status
        );
        search.report.solver_seconds
    }

    fn joint_step(&self) -> f64 {
        let step = joint_step::<S>(&self.data, &self.model, 0.1, &self.options)
            .expect("the joint step runs");
        assert!(step.report.status.is_usable(), "{:?}", step.report.status);
        step.report.solver_seconds
    }
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

/// Wall time of one run of `f`.
fn time(f: impl Fn() -> f64) -> f64 {
    let start = Instant::now();
    black_box(f());
    start.elapsed().as_secs_f64()
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let data = reference_samples::<DragDuffing>(1000, 1, |rng| loop {
        let x: Vec<f64> = (0..2).map(|_| rng.random_range(-2.0..2.0)).collect();
        if x[0] * x[0] + x[1] * x[1] <= 4.0 {
            return x;
        }
    });
    let entropy = DragDuffing::REFERENCE_ENTROPY
        .expect("a reference")
        .to_vec();
    let with = Case::<DragDuffing>::new(&data, &entropy);
    let without = Case::<DragDuffingWithoutRegion>::new(&data, &entropy);

    let mut criterion = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(if quick { 200 } else { 1000 }))
        .measurement_time(Duration::from_secs(if quick { 1 } else { 5 }))
        .configure_from_args();
    let mut group = criterion.benchmark_group("region");
    group.bench_function("metric search, without region", |b| {
        b.iter(|| without.metric_search())
    });
    group.bench_function("metric search, with region", |b| {
        b.iter(|| with.metric_search())
    });
    group.bench_function("joint step, without region", |b| {
        b.iter(|| without.joint_step())
    });
    group.bench_function("joint step, with region", |b| b.iter(|| with.joint_step()));
    group.finish();

    // Ratios from interleaved timing in this process.
    let repeats = if quick { 5 } else { 15 };
    println!("\n| | without region | with region | ratio |\n| --- | --- | --- | --- |");
    type Solve<'a> = Box<dyn Fn() -> f64 + 'a>;
    let rows: [(&str, Solve, Solve); 2] = [
        (
            "metric search",
            Box::new(|| without.metric_search()),
            Box::new(|| with.metric_search()),
        ),
        (
            "joint step",
            Box::new(|| without.joint_step()),
            Box::new(|| with.joint_step()),
        ),
    ];
    for (name, plain, region) in rows {
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for _ in 0..repeats {
            a.push(time(&plain));
            b.push(time(&region));
        }
        let (a, b) = (median(a), median(b));
        println!(
            "| {name} | {:.1} ms | {:.1} ms | {:.1}× |",
            1e3 * a,
            1e3 * b,
            b / a
        );
    }
}
