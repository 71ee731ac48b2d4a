//! Larger systems: the entropy search of a 6-state system against the
//! floor of its interior-point iterations, across cores and sample counts.
//!
//! The system is three coupled oscillators with the canonical Poisson
//! tensor and a constant metric (metric degree 0), declared with entropy
//! degree 4 (p = 209 coefficients) and 6 (p = 923). Every solve is the
//! entropy search on q exact samples of the reference model with the
//! metric held at the identity, which is not the truth, so the optimum is
//! not zero (as in an identification's middle iterations).
//!
//! * Criterion (10 samples): the degree-4 solve at q = 2000, and the floor
//!   kernel of both degrees.
//! * Then a report, one run per row, printed as Markdown for BENCHMARKS.md:
//!   time per interior-point iteration against the floor (one Aᵀ D A of the
//!   problem's own regression block plus its Cholesky factorisation, with
//!   faer on all cores), one core against all, the fitted growth in q over
//!   q = 2000…16000 and in p, and whether the coefficients have the same
//!   bits on one thread as on all. Each row also counts the residuals the
//!   optimum fits exactly (below 1e-9; a vertex of the L1 problem has about
//!   p) and nearly (in [1e-9, 1e-5)): the interior-point method must tell
//!   the two apart, and in these runs its iteration count follows the
//!   nearly fitted ones.
//! * The degree-6 series again with Gaussian noise (standard deviation
//!   1e-3) on ẋ, as measured data have.
//! * Whole identifications (`identify` with the default configuration) on
//!   the same exact samples, q = 2000…16000 at degrees 4 and 6: what a
//!   user waits for, including the start (an entropy search at the
//!   identity metric on at most 2000 samples), the warm-up's iterations on
//!   those samples, the metric, entropy and joint steps on all of them,
//!   and the final checks. `-- --whole --noisy` runs them on the noisy
//!   samples instead, `--cold` without the warm-up and `--no-restart`
//!   without the restart of stagnated runs.
//!
//! `cargo bench --bench scale` (about 20 min on 2 cores); `-- --quick` stops
//! at q = 4000; `-- --peak` runs only the degree-6 solve at q = 16000 and
//! prints the process's peak resident memory; `-- --whole` runs only the
//! whole identifications (`-- --whole --noisy` on noisy samples, `--cold`
//! without the warm-up).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::Criterion;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::triangular::{matmul, BlockStructure};
use faer::{Accum, MatMut, MatRef, Par};
use metriplectic::systems::reference_samples;
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{entropy_search, SearchOptions, SearchReport, SolveStatus};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;

metriplectic! {
    /// Three coupled oscillators, entropy degree 6.
    pub struct ChainDegree6;
    state (q1, q2, q3, p1, p2, p3);
    const c = 0.25;
    poisson = [
        [0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1],
        [-1, 0, 0, 0, 0, 0], [0, -1, 0, 0, 0, 0], [0, 0, -1, 0, 0, 0],
    ];
    hamiltonian = 0.5 * (p1^2 + p2^2 + p3^2) + 0.5 * (q1^2 + q2^2 + q3^2)
        + c * ((q2 - q1)^2 + (q3 - q2)^2);
    entropy degree 6;
    metric degree 0;
    reference {
        entropy = -0.25 * (p1^2 + p2^2 + p3^2 + q1^2 + q2^2 + q3^2 - 1)^2 - 0.5 * q1 * p2;
        metric = [[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0],
                  [0, 0, 0, 1, 0.2, 0], [0, 0, 0, 0.2, 1, 0], [0, 0, 0, 0, 0, 1]];
    }
}

metriplectic! {
    /// Three coupled oscillators, entropy degree 4.
    pub struct ChainDegree4;
    state (q1, q2, q3, p1, p2, p3);
    const c = 0.25;
    poisson = [
        [0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1],
        [-1, 0, 0, 0, 0, 0], [0, -1, 0, 0, 0, 0], [0, 0, -1, 0, 0, 0],
    ];
    hamiltonian = 0.5 * (p1^2 + p2^2 + p3^2) + 0.5 * (q1^2 + q2^2 + q3^2)
        + c * ((q2 - q1)^2 + (q3 - q2)^2);
    entropy degree 4;
    metric degree 0;
    reference {
        entropy = -0.25 * (p1^2 + p2^2 + p3^2 + q1^2 + q2^2 + q3^2 - 1)^2 - 0.5 * q1 * p2;
        metric = [[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0],
                  [0, 0, 0, 1, 0.2, 0], [0, 0, 0, 0.2, 1, 0], [0, 0, 0, 0, 0, 1]];
    }
}

/// The noise of the noisy series: a standard deviation of 1e-3 on every
/// component of ẋ (the derivatives are of order 1).
const NOISE: f64 = 1e-3;

/// One entropy search: the data, the metric it holds fixed, and its timing.
struct Case<S: MetriplecticSystem> {
    data: Dataset,
    metric: Vec<f64>,
    marker: std::marker::PhantomData<S>,
}

/// What one solve measured.
struct Solve {
    seconds: f64,
    solver_seconds: f64,
    iterations: u32,
    coefficients: Vec<f64>,
}

impl Solve {
    fn per_iteration(&self) -> f64 {
        self.solver_seconds / f64::from(self.iterations.max(1))
    }
}

impl<S: MetriplecticSystem> Case<S> {
    fn new(q: usize) -> Self {
        Self::with_noise(q, 0.0)
    }

    /// q samples with Gaussian noise of standard deviation `noise` added to
    /// every component of ẋ (0: exact).
    fn with_noise(q: usize, noise: f64) -> Self {
        let exact = reference_samples::<S>(q, 1, |rng| {
            (0..6).map(|_| rng.random_range(-1.2..1.2)).collect()
        });
        let data = if noise > 0.0 {
            let mut rng = ChaCha8Rng::seed_from_u64(11);
            let normal = Normal::new(0.0, noise).expect("a positive standard deviation");
            let derivatives = exact
                .derivatives()
                .iter()
                .map(|d| d + normal.sample(&mut rng))
                .collect();
            Dataset::from_flat(S::DIM, exact.states().to_vec(), derivatives)
                .expect("finite noisy data")
        } else {
            exact
        };
        let identity = Model::<S>::with_identity_metric(vec![0.0; S::entropy_coefficient_count()])
            .expect("valid coefficients");
        Self {
            data,
            metric: identity.metric_coefficients().to_vec(),
            marker: std::marker::PhantomData,
        }
    }

    fn solve(&self) -> Solve {
        let start = Instant::now();
        let search = entropy_search::<S>(&self.data, &self.metric, &SearchOptions::default())
            .expect("the entropy search runs");
        let seconds = start.elapsed().as_secs_f64();
        assert!(
            search.report.status.is_usable(),
            "{:?}",
            search.report.status
        );
        Solve {
            seconds,
            solver_seconds: search.report.solver_seconds,
            iterations: search.report.iterations,
            coefficients: search.coefficients,
        }
    }

    /// The residuals of the entropy `coefficients` (with the metric held)
    /// below 1e-9, fitted exactly (a vertex of the L1 problem fits about p),
    /// and in [1e-9, 1e-5), fitted nearly: the interior-point method must
    /// still tell those from the fitted ones.
    fn residual_counts(&self, coefficients: &[f64]) -> (usize, usize) {
        let fitted = Model::<S>::new(coefficients.to_vec(), self.metric.clone())
            .expect("the search returns valid coefficients");
        let mut field = vec![0.0; S::DIM];
        let (mut exactly, mut nearly) = (0, 0);
        for (x, derivative) in self.data.iter() {
            fitted
                .vector_field(x, &mut field)
                .expect("a state of the system");
            for (d, f) in derivative.iter().zip(&field) {
                match (d - f).abs() {
                    r if r < 1e-9 => exactly += 1,
                    r if r < 1e-5 => nearly += 1,
                    _ => {}
                }
            }
        }
        (exactly, nearly)
    }

    /// The search's regression block (r × p, row-major), assembled like
    /// the runtime assembles it: M J(x)ᵀ per sample with M = K + Π.
    fn regression(&self) -> (usize, usize, Vec<f64>) {
        let (n, p) = (S::DIM, S::entropy_coefficient_count());
        let mut k = vec![0.0; n * n];
        let mut block = vec![0.0; n * p];
        let mut drift = vec![0.0; n];
        let mut rows = Vec::with_capacity(self.data.len() * n * p);
        for i in 0..self.data.len() {
            let x = self.data.state(i);
            S::metric_value(x, &self.metric, &mut k);
            S::entropy_block(x, &k, &mut block, &mut drift);
            rows.extend_from_slice(&block);
        }
        (self.data.len() * n, p, rows)
    }
}

/// The floor of one interior-point iteration: Aᵀ D A of the problem's own
/// regression block and a random positive D (the rows scaled by √D on
/// every core into a buffer allocated once, then faer's lower-triangular product), and its
/// Cholesky factorisation, all with faer on every core.
struct Floor {
    rows: usize,
    columns: usize,
    a: Vec<f64>,
    d: Vec<f64>,
    scaled: Vec<f64>,
    schur: Vec<f64>,
}

impl Floor {
    fn new((rows, columns, a): (usize, usize, Vec<f64>)) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let d = (0..rows).map(|_| rng.random_range(0.5..2.0)).collect();
        Self {
            rows,
            columns,
            scaled: vec![0.0; a.len()],
            a,
            d,
            schur: vec![0.0; columns * columns],
        }
    }

    fn run(&mut self) -> f64 {
        let (r, k) = (self.rows, self.columns);
        let start = Instant::now();
        self.scaled
            .par_chunks_exact_mut(k)
            .zip(self.a.par_chunks_exact(k))
            .zip(&self.d)
            .for_each(|((target, row), d)| {
                let root = d.sqrt();
                target.iter_mut().zip(row).for_each(|(t, a)| *t = root * a);
            });
        let scaled = MatRef::from_row_major_slice(&self.scaled, r, k);
        matmul(
            MatMut::from_column_major_slice_mut(&mut self.schur, k, k),
            BlockStructure::TriangularLower,
            Accum::Replace,
            scaled.transpose(),
            BlockStructure::Rectangular,
            scaled,
            BlockStructure::Rectangular,
            1.0,
            Par::rayon(0),
        );
        let par = Par::rayon(0);
        let mut memory = MemBuffer::new(
            faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<f64>(
                k,
                par,
                Default::default(),
            ),
        );
        faer::linalg::cholesky::llt::factor::cholesky_in_place(
            MatMut::from_column_major_slice_mut(&mut self.schur, k, k),
            Default::default(),
            par,
            MemStack::new(&mut memory),
            Default::default(),
        )
        .expect("Aᵀ D A is positive definite");
        start.elapsed().as_secs_f64()
    }

    /// Median of `repeats` runs.
    fn median(&mut self, repeats: usize) -> f64 {
        median((0..repeats).map(|_| self.run()).collect())
    }
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

/// Least-squares slope of log y against log x.
fn log_log_slope(points: &[(f64, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points.iter().map(|(x, y)| (x.ln(), y.ln())).collect();
    let n = logs.len() as f64;
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = logs.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = logs.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

/// `f` on a rayon pool of `threads` threads (faer's kernels and the
/// runtime's parallel loops use the current pool).
fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
        .install(f)
}

/// Peak resident memory of this process (VmHWM), in MiB.
fn peak_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// Rows of the q-series for one degree and noise level: q, p, IPM
/// iterations, seconds per solve and per IPM iteration, the floor, the
/// ratio, and the residuals fitted exactly and nearly at the optimum.
fn q_series<S: MetriplecticSystem>(qs: &[usize], noise: f64) -> Vec<(usize, Solve, f64)> {
    let mut rows = Vec::new();
    for &q in qs {
        let case = Case::<S>::with_noise(q, noise);
        let floor = Floor::new(case.regression()).median(3);
        let solve = case.solve();
        let (exactly, nearly) = case.residual_counts(&solve.coefficients);
        println!(
            "| {} | {q} | {} | {:.2} | {:.1} | {:.1} | {:.2}× | {exactly} | {nearly} |",
            S::entropy_coefficient_count(),
            solve.iterations,
            solve.seconds,
            1e3 * solve.per_iteration(),
            1e3 * floor,
            solve.per_iteration() / floor,
        );
        rows.push((q, solve, floor));
    }
    rows
}

/// Whole identifications on exact samples: one row per q (alternation
/// iterations, recorded solves, their IPM iterations, wall time, the time
/// inside the recorded solves, the held-out error against the truth), and
/// the wall time's growth in q.
fn identification_series<S: MetriplecticSystem>(qs: &[usize], noise: f64, config: &IdentifyConfig) {
    let truth = Model::<S>::reference().expect("the system declares its truth");
    let held_out = reference_samples::<S>(500, 77, |rng| {
        (0..6).map(|_| rng.random_range(-1.2..1.2)).collect()
    });
    let mut walls = Vec::new();
    for &q in qs {
        let case = Case::<S>::with_noise(q, noise);
        let start = Instant::now();
        let fit = identify::<S>(&case.data, config).expect("identification runs");
        let wall = start.elapsed().as_secs_f64();
        let steps: Vec<&SearchReport> = fit
            .history
            .iterations
            .iter()
            .flat_map(|r| {
                [
                    Some(&r.metric),
                    Some(&r.entropy),
                    r.joint.as_ref().map(|j| &j.step),
                ]
                .into_iter()
                .flatten()
                .map(|step| &step.report)
            })
            .collect();
        let ipm: u32 = steps.iter().map(|r| r.iterations).sum();
        let inside: f64 = steps
            .iter()
            .map(|r| r.solver_seconds + r.assembly_seconds)
            .sum();
        let error = fit
            .model
            .compare(&truth, &held_out)
            .expect("comparable models")
            .relative_error;
        // The steps that did not end Solved, by status: a false failure
        // shows here even when the run still converges.
        let unsolved: Vec<String> = steps
            .iter()
            .filter(|r| r.status != SolveStatus::Solved)
            .map(|r| format!("{:?}", r.status))
            .collect();
        let unsolved = if unsolved.is_empty() {
            "none".to_owned()
        } else {
            unsolved.join(", ")
        };
        let warm_up = fit.history.iterations.iter().filter(|r| r.warm_up).count();
        let restart = fit.history.iterations.iter().filter(|r| r.restart).count();
        println!(
            "| {} | {q} | {:?} | {} ({warm_up}, {restart}) | {} | {unsolved} | {ipm} | {wall:.1} | {inside:.1} | {:.1} | {error:.1e} |",
            S::entropy_coefficient_count(),
            fit.stop_reason,
            fit.history.iterations.len(),
            steps.len(),
            wall - inside,
        );
        walls.push((q as f64, wall));
    }
    println!(
        "\np = {}: wall ∝ q^{:.2} (q = {}…{})\n",
        S::entropy_coefficient_count(),
        log_log_slope(&walls),
        qs[0],
        qs[qs.len() - 1]
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    if args.iter().any(|a| a == "--peak") {
        let case = Case::<ChainDegree6>::new(16000);
        let solve = case.solve();
        println!(
            "entropy degree 6 (p = 923), q = 16000: {:.1} s, {} IPM iterations; peak RSS {:.0} MiB",
            solve.seconds,
            solve.iterations,
            peak_mib().unwrap_or(f64::NAN)
        );
        return;
    }
    let qs: &[usize] = if quick {
        &[2000, 4000]
    } else {
        &[2000, 4000, 8000, 16000]
    };
    if args.iter().any(|a| a == "--whole") {
        let noisy = args.iter().any(|a| a == "--noisy");
        let config = IdentifyConfig {
            warm_up: !args.iter().any(|a| a == "--cold"),
            restart_on_stagnation: !args.iter().any(|a| a == "--no-restart"),
            ..IdentifyConfig::default()
        };
        whole_identifications(qs, if noisy { NOISE } else { 0.0 }, &config);
        return;
    }

    let small = Case::<ChainDegree4>::new(2000);
    let mut floor4 = Floor::new(small.regression());
    let mut floor6 = Floor::new(Case::<ChainDegree6>::new(2000).regression());
    let mut criterion = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(if quick { 200 } else { 1000 }))
        .measurement_time(Duration::from_secs(if quick { 2 } else { 8 }))
        .configure_from_args();
    let mut group = criterion.benchmark_group("scale");
    group.bench_function("entropy search, degree 4, q = 2000", |b| {
        b.iter(|| black_box(small.solve().iterations))
    });
    group.bench_function("floor, degree 4, q = 2000", |b| {
        b.iter(|| black_box(floor4.run()))
    });
    group.bench_function("floor, degree 6, q = 2000", |b| {
        b.iter(|| black_box(floor6.run()))
    });
    group.finish();

    println!("\n### Time per interior-point iteration against the floor (all cores)\n");
    let header = || {
        println!(
            "| p | q | IPM iterations | solve (s) | per IPM iteration (ms) | floor (ms) | ratio | residuals < 1e-9 | in [1e-9, 1e-5) |"
        );
        println!("|---|---|---|---|---|---|---|---|---|");
    };
    header();
    let degree4 = q_series::<ChainDegree4>(qs, 0.0);
    let degree6 = q_series::<ChainDegree6>(qs, 0.0);
    println!("\nThe same degree-6 searches with noise of standard deviation {NOISE:e} on ẋ:\n");
    header();
    let noisy6 = q_series::<ChainDegree6>(qs, NOISE);

    println!("\n### Growth\n");
    for (label, rows) in [
        ("p = 209", &degree4),
        ("p = 923", &degree6),
        ("p = 923, noisy", &noisy6),
    ] {
        let solves: Vec<(f64, f64)> = rows
            .iter()
            .map(|(q, s, _)| (*q as f64, s.seconds))
            .collect();
        let iterations: Vec<(f64, f64)> = rows
            .iter()
            .map(|(q, s, _)| (*q as f64, s.per_iteration()))
            .collect();
        let counts: Vec<(f64, f64)> = rows
            .iter()
            .map(|(q, s, _)| (*q as f64, f64::from(s.iterations)))
            .collect();
        println!(
            "{label}: solve ∝ q^{:.2}, per IPM iteration ∝ q^{:.2}, IPM iterations ∝ q^{:.2} (q = {}…{})",
            log_log_slope(&solves),
            log_log_slope(&iterations),
            log_log_slope(&counts),
            qs[0],
            qs[qs.len() - 1]
        );
    }
    let per_p: Vec<(f64, f64)> = [(209.0, &degree4), (923.0, &degree6)]
        .iter()
        .map(|(p, rows)| (*p, rows[0].1.per_iteration()))
        .collect();
    println!(
        "q = {}: per IPM iteration ∝ p^{:.2} (p = 209, 923)",
        qs[0],
        log_log_slope(&per_p)
    );

    println!("\n### One core against all\n");
    println!("| p | q | threads | solve (s) | per IPM iteration (ms) | floor (ms) | speed-up | same bits |");
    println!("|---|---|---|---|---|---|---|---|");
    let case = Case::<ChainDegree6>::new(2000);
    let all = rayon::current_num_threads();
    let (one_solve, one_floor) = on_threads(1, || {
        (case.solve(), Floor::new(case.regression()).median(3))
    });
    let all_solve = case.solve();
    let all_floor = Floor::new(case.regression()).median(3);
    let same = one_solve
        .coefficients
        .iter()
        .zip(&all_solve.coefficients)
        .all(|(a, b)| a.to_bits() == b.to_bits());
    for (threads, solve, floor) in [(1, &one_solve, one_floor), (all, &all_solve, all_floor)] {
        println!(
            "| 923 | 2000 | {threads} | {:.2} | {:.1} | {:.1} | {:.2}× | {} |",
            solve.seconds,
            1e3 * solve.per_iteration(),
            1e3 * floor,
            one_solve.seconds / solve.seconds,
            if same { "yes" } else { "no" },
        );
    }

    whole_identifications(qs, 0.0, &IdentifyConfig::default());
}

/// Whole identifications at both degrees with `config` on exact samples
/// (`noise` 0) or with Gaussian noise of that standard deviation on ẋ.
fn whole_identifications(qs: &[usize], noise: f64, config: &IdentifyConfig) {
    let warm_up = match (config.warm_up, config.restart_on_stagnation) {
        (true, true) => "",
        (false, true) => ", no warm-up",
        (true, false) => ", no restart",
        (false, false) => ", no warm-up, no restart",
    };
    if noise > 0.0 {
        println!("\n### Whole identifications (noise {noise:e} on ẋ{warm_up})\n");
    } else {
        println!("\n### Whole identifications (exact samples{warm_up})\n");
    }
    println!(
        "| p | q | stop | iterations (warm-up, restart) | solves | not Solved | IPM iterations | wall (s) | in the solves (s) | other (s) | held-out error |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    identification_series::<ChainDegree4>(qs, noise, config);
    identification_series::<ChainDegree6>(qs, noise, config);
}
