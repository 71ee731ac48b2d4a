//! Where the time of an identification iteration goes.
//!
//! A report bench (`harness = false`, plain timing: each measured thing takes
//! 0.1–10 s, so a few repetitions say more than criterion's statistics):
//!
//! 1. one Algorithm-2 iteration at q = 2000 for both paper systems and both
//!    solver backends, split into assembly and solver (the runtime's
//!    `SolveReport` timings) and the rest of the wall time;
//! 2. scaling of the iteration time (dense backend) with q and with the
//!    entropy degree, with the fitted log-log slope; then the paper-sized
//!    SO(3) run (350 iterations at q = 2000) end to end;
//! 3. the metric search with both backends, and the entropy LP with the
//!    dense backend and Clarabel's three `L1Formulation`s at q = 2000;
//! 4. Clarabel setup against iterations, and reusing the solver across
//!    minibatches (`update_A`/`update_b`) against rebuilding it;
//! 5. the floor: time per interior-point iteration of both backends against
//!    a dense Aᵀ D A of the LP's shape (the p×p Schur complement on ψ).
//!
//! `cargo bench --bench identification` (add `-- --quick` for a shorter run
//! without q > 2000 and without the paper-sized run;
//! `-- --peak` runs only the largest scaling point and prints the peak RSS).
//! Tables are printed as Markdown for BENCHMARKS.md. The SO(3) entropy LP at
//! q = 2000 is written to `target/bench-data/` for `scripts/faer_ldl.sh`.

use std::ops::ControlFlow;
use std::time::Instant;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SupportedConeT};
use metriplectic::systems::{
    linear2d_data, perturbed_reference_entropy, rigid_body_data, Linear2d, RigidBody,
};
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    entropy_search, identify_with_observer, metric_search, model_cost, IterationRecord,
    L1Formulation, SearchOptions, SolverBackend, SolverSettings,
};
use nalgebra::DMatrix;
use rand::seq::index::sample;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// θ of K = c·I.
fn identity_metric<S: MetriplecticSystem>(scale: f64) -> Vec<f64> {
    let unit = Model::<S>::with_identity_metric(vec![0.0; S::entropy_coefficient_count()])
        .expect("valid coefficients");
    unit.metric_coefficients()
        .iter()
        .map(|t| t * scale)
        .collect()
}

/// Position of the upper-triangle pair (j, k) among the n(n+1)/2 pairs of θ.
fn metric_pair_index(dim: usize, j: usize, k: usize) -> usize {
    let (j, k) = (j.min(k), j.max(k));
    j * dim - j * j.saturating_sub(1) / 2 + (k - j)
}

metriplectic! {
    /// The SO(3) rigid body with an entropy basis of degree 4.
    pub struct RigidBodyDegree4;
    state (px, py, pz);
    const j1 = 0.1;
    const j2 = 0.2;
    const j3 = 0.15;
    poisson = [[0, -pz, py], [pz, 0, -px], [-py, px, 0]];
    hamiltonian = 0.5 * (px^2 / j1 + py^2 / j2 + pz^2 / j3);
    entropy degree 4;
    metric degree 2;
    reference {
        entropy = -0.5 * (px^2 + py^2 + pz^2 - 1)^2 - 0.5 * (px^2 / j1 + py^2 / j2 + pz^2 / j3);
        metric = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
    }
}

metriplectic! {
    /// The SO(3) rigid body with an entropy basis of degree 8.
    pub struct RigidBodyDegree8;
    state (px, py, pz);
    const j1 = 0.1;
    const j2 = 0.2;
    const j3 = 0.15;
    poisson = [[0, -pz, py], [pz, 0, -px], [-py, px, 0]];
    hamiltonian = 0.5 * (px^2 / j1 + py^2 / j2 + pz^2 / j3);
    entropy degree 8;
    metric degree 2;
    reference {
        entropy = -0.5 * (px^2 + py^2 + pz^2 - 1)^2 - 0.5 * (px^2 / j1 + py^2 / j2 + pz^2 / j3);
        metric = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
    }
}

/// Timings of one identification iteration.
#[derive(Debug, Clone, Copy, Default)]
struct IterationTiming {
    wall: f64,
    assembly: f64,
    solver: f64,
    metric_ipm: u32,
    entropy_ipm: u32,
}

impl IterationTiming {
    fn other(&self) -> f64 {
        self.wall - self.assembly - self.solver
    }
}

/// Runs `iterations` Algorithm-2 iterations of batch size q from the paper's
/// perturbed initial entropy and returns the timing of each.
fn time_iterations<S: MetriplecticSystem>(
    data: &Dataset,
    q: usize,
    sigma: f64,
    iterations: usize,
    backend: SolverBackend,
) -> Vec<IterationTiming> {
    let config = IdentifyConfig {
        search: SearchOptions {
            solver: SolverSettings {
                backend,
                ..SolverSettings::default()
            },
            ..SearchOptions::default()
        },
        batch_size: Some(q),
        max_iterations: iterations,
        tolerance: 0.0,
        seed: 3,
        initial_entropy: Some(perturbed_reference_entropy::<S>(sigma, 5)),
        ..IdentifyConfig::default()
    };
    let mut timings = Vec::with_capacity(iterations);
    let mut last = Instant::now();
    let result =
        identify_with_observer::<S, _>(data, &config, |record: &IterationRecord, _model| {
            let now = Instant::now();
            timings.push(IterationTiming {
                wall: (now - last).as_secs_f64(),
                assembly: record.metric.report.assembly_seconds
                    + record.entropy.report.assembly_seconds,
                solver: record.metric.report.solver_seconds + record.entropy.report.solver_seconds,
                metric_ipm: record.metric.report.iterations,
                entropy_ipm: record.entropy.report.iterations,
            });
            last = Instant::now();
            ControlFlow::Continue(())
        });
    result.expect("identification runs");
    timings
}

/// The median iteration (by wall time) of `timings`.
fn median(timings: &[IterationTiming]) -> IterationTiming {
    let mut sorted = timings.to_vec();
    sorted.sort_by(|a, b| a.wall.total_cmp(&b.wall));
    sorted[sorted.len() / 2]
}

fn median_of(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

/// Least-squares slope of log(y) against log(x).
fn log_log_slope(points: &[(f64, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points.iter().map(|(x, y)| (x.ln(), y.ln())).collect();
    let n = logs.len() as f64;
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = logs.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = logs.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

fn split_row(name: &str, q: usize, timings: &[IterationTiming]) {
    let t = median(timings);
    println!(
        "| {name} | {q} | {:.3} | {:.4} ({:.1}%) | {:.3} ({:.1}%) | {:.4} ({:.1}%) | {:.1}% | {} + {} |",
        t.wall,
        t.assembly,
        100.0 * t.assembly / t.wall,
        t.solver,
        100.0 * t.solver / t.wall,
        t.other(),
        100.0 * t.other() / t.wall,
        100.0 * (t.assembly + t.other()) / t.wall,
        t.metric_ipm,
        t.entropy_ipm,
    );
}

/// The Split-formulation entropy LP of one batch, built exactly like the
/// runtime builds it (variables [ψ | u | v], rows [Aψ + u − v = t ; −u ≤ 0 ;
/// −v ≤ 0 ; ±ψ ≤ η]) but keeping explicit zeros, so that every batch has
/// the same sparsity pattern and the solver can be reused.
struct EntropyLp {
    /// Dense regression block A (r × p, row-major) and targets t.
    rows: Vec<f64>,
    target: Vec<f64>,
    p: usize,
    q_vec: Vec<f64>,
    a: CscMatrix<f64>,
    b: Vec<f64>,
    cones: Vec<SupportedConeT<f64>>,
}

fn entropy_lp<S: MetriplecticSystem>(batch: &Dataset, metric: &[f64], eta: f64) -> EntropyLp {
    let n = S::DIM;
    let p = S::entropy_coefficient_count();
    let mut k = vec![0.0; n * n];
    let mut block = vec![0.0; n * p];
    let mut drift = vec![0.0; n];
    let mut rows = Vec::with_capacity(batch.len() * n * p);
    let mut target = Vec::with_capacity(batch.len() * n);
    for (x, xdot) in batch.iter() {
        S::metric_value(x, metric, &mut k);
        S::entropy_block(x, &k, &mut block, &mut drift);
        rows.extend_from_slice(&block);
        target.extend(xdot.iter().zip(&drift).map(|(v, d)| v - d));
    }
    let r = target.len();
    let (n_vars, n_rows) = (p + 2 * r, 3 * r + 2 * p);
    let mut colptr = vec![0];
    let mut rowval = Vec::with_capacity(r * p + 4 * r + 2 * p);
    let mut nzval = Vec::with_capacity(r * p + 4 * r + 2 * p);
    for c in 0..p {
        for i in 0..r {
            rowval.push(i);
            nzval.push(rows[i * p + c]);
        }
        rowval.extend([3 * r + c, 3 * r + p + c]);
        nzval.extend([1.0, -1.0]);
        colptr.push(rowval.len());
    }
    for (offset, sign) in [(r, 1.0), (2 * r, -1.0)] {
        for i in 0..r {
            rowval.extend([i, offset + i]);
            nzval.extend([sign, -1.0]);
            colptr.push(rowval.len());
        }
    }
    let mut q_vec = vec![0.0; n_vars];
    q_vec[p..].fill(1.0);
    let mut b = vec![0.0; n_rows];
    b[..r].copy_from_slice(&target);
    b[3 * r..].fill(eta);
    EntropyLp {
        rows,
        target,
        p,
        q_vec,
        a: CscMatrix::new(n_rows, n_vars, colptr, rowval, nzval),
        b,
        cones: vec![
            SupportedConeT::ZeroConeT(r),
            SupportedConeT::NonnegativeConeT(2 * r + 2 * p),
        ],
    }
}

fn clarabel_settings() -> DefaultSettings<f64> {
    DefaultSettings {
        verbose: false,
        ..DefaultSettings::default()
    }
}

/// Setup seconds, solve seconds, IPM iterations, objective, nnz(L) of one
/// fresh Clarabel solve.
struct Fresh {
    setup: f64,
    solve: f64,
    iterations: u32,
    objective: f64,
    nnz_kkt: usize,
    nnz_l: usize,
}

fn solve_fresh(lp: &EntropyLp) -> (Fresh, DefaultSolver<f64>) {
    let p = CscMatrix::zeros((lp.q_vec.len(), lp.q_vec.len()));
    let start = Instant::now();
    let mut solver =
        DefaultSolver::new(&p, &lp.q_vec, &lp.a, &lp.b, &lp.cones, clarabel_settings())
            .expect("valid LP");
    let setup = start.elapsed().as_secs_f64();
    let start = Instant::now();
    solver.solve();
    let solve = start.elapsed().as_secs_f64();
    let fresh = Fresh {
        setup,
        solve,
        iterations: solver.solution.iterations,
        objective: solver.solution.obj_val,
        nnz_kkt: solver.info.linsolver.nnzA,
        nnz_l: solver.info.linsolver.nnzL,
    };
    (fresh, solver)
}

/// Writes the LP as JSON for the throwaway faer comparison.
fn dump(lp: &EntropyLp, path: &std::path::Path) -> std::io::Result<()> {
    let cones: Vec<(&str, usize)> = lp
        .cones
        .iter()
        .map(|c| match c {
            SupportedConeT::ZeroConeT(d) => ("zero", *d),
            SupportedConeT::NonnegativeConeT(d) => ("nonneg", *d),
            _ => unreachable!("the entropy LP has only zero and nonnegative cones"),
        })
        .collect();
    let json = serde_json::json!({
        "m": lp.a.m, "n": lp.a.n, "colptr": lp.a.colptr, "rowval": lp.a.rowval,
        "nzval": lp.a.nzval, "q": lp.q_vec, "b": lp.b, "cones": cones,
    });
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(path, json.to_string())
}

fn random_batch(data: &Dataset, q: usize, seed: u64) -> Dataset {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    data.select(&sample(&mut rng, data.len(), q).into_vec())
        .expect("indices in range")
}

/// Section 3 to 5 for one system at batch size q.
fn solver_sections<S: MetriplecticSystem>(
    data: &Dataset,
    q: usize,
    repeats: usize,
    dump_to: Option<&str>,
) {
    let eta = 20.0;
    let batch = random_batch(data, q, 11);
    // A constant K that is not the truth (K = I with K₀₁ = K₁₀ = 0.3):
    // no entropy fits it exactly, so the optimum is not zero and comparing
    // objectives below checks something.
    let mut metric = identity_metric::<S>(1.0);
    metric[metric_pair_index(S::DIM, 0, 1) * S::METRIC_EXPONENTS.len()] = 0.3;

    // The metric search on the same batch, from the paper's initial entropy.
    let entropy = perturbed_reference_entropy::<S>(1.0, 5);
    println!(
        "\n#### {} — metric search (q = {q}, reduced SOS, θ has {} coefficients)\n",
        S::NAME,
        S::metric_coefficient_count(),
    );
    println!("| backend | solver (s, median of {repeats}) | IPM iterations | per IPM iteration (ms) | assembly (s) | cost (sum) | status |");
    println!("|---|---|---|---|---|---|---|");
    for backend in [
        SolverBackend::Dense,
        SolverBackend::Clarabel(L1Formulation::default()),
    ] {
        let options = SearchOptions {
            eta: Some(eta),
            solver: SolverSettings {
                backend,
                ..SolverSettings::default()
            },
            ..SearchOptions::default()
        };
        let mut solver = Vec::new();
        let mut last = None;
        for _ in 0..repeats {
            let fit = metric_search::<S>(&batch, &entropy, &options).expect("metric search");
            solver.push(fit.report.solver_seconds);
            last = Some(fit.report);
        }
        let report = last.expect("at least one repeat");
        let solver = median_of(&mut solver);
        println!(
            "| {backend:?} | {solver:.3} | {} | {:.1} | {:.4} | {:.6e} | {} |",
            report.iterations,
            1e3 * solver / f64::from(report.iterations.max(1)),
            report.assembly_seconds,
            report.cost.map_or(f64::NAN, |c| c.sum),
            report.status,
        );
    }

    // 3. The runtime's three formulations on the same batch.
    println!(
        "\n#### {} — entropy LP: dense backend and Clarabel's formulations (q = {q}, K = I + 0.3 (e₀e₁ᵀ + e₁e₀ᵀ))\n",
        S::NAME
    );
    println!("| backend / formulation | solver (s, median of {repeats}) | IPM iterations | per IPM iteration (ms) | assembly (s) | cost (sum) | status |");
    println!("|---|---|---|---|---|---|---|");
    let mut split_cost = None;
    let mut dense_per_iteration = f64::NAN;
    for (backend, formulation) in [
        (SolverBackend::Dense, L1Formulation::Split),
        (
            SolverBackend::Clarabel(L1Formulation::Slack),
            L1Formulation::Slack,
        ),
        (
            SolverBackend::Clarabel(L1Formulation::ExplicitResidual),
            L1Formulation::ExplicitResidual,
        ),
        (
            SolverBackend::Clarabel(L1Formulation::Split),
            L1Formulation::Split,
        ),
    ] {
        let options = SearchOptions {
            eta: Some(eta),
            solver: SolverSettings {
                backend,
                ..SolverSettings::default()
            },
            ..SearchOptions::default()
        };
        let mut solver = Vec::new();
        let mut assembly = Vec::new();
        let mut last = None;
        for _ in 0..repeats {
            let fit = entropy_search::<S>(&batch, &metric, &options).expect("entropy search");
            solver.push(fit.report.solver_seconds);
            assembly.push(fit.report.assembly_seconds);
            last = Some(fit.report);
        }
        let report = last.expect("at least one repeat");
        let cost = report.cost.map_or(f64::NAN, |c| c.sum);
        let solver = median_of(&mut solver);
        let label = match backend {
            SolverBackend::Dense => {
                dense_per_iteration = solver / f64::from(report.iterations.max(1));
                "Dense (default)".to_owned()
            }
            _ => {
                if formulation == L1Formulation::Split {
                    split_cost = Some(cost);
                }
                format!("Clarabel, {formulation:?}")
            }
        };
        println!(
            "| {label} | {solver:.3} | {} | {:.1} | {:.4} | {cost:.6e} | {} |",
            report.iterations,
            1e3 * solver / f64::from(report.iterations.max(1)),
            median_of(&mut assembly),
            report.status,
        );
    }

    // 4. Setup against iterations; reuse across minibatches.
    let lp = entropy_lp::<S>(&batch, &metric, eta);
    if let Some(path) = dump_to {
        match dump(&lp, std::path::Path::new(path)) {
            Ok(()) => println!("\n(LP written to {path})"),
            Err(e) => println!("\n(could not write {path}: {e})"),
        }
    }
    let mut runs: Vec<Fresh> = (0..repeats).map(|_| solve_fresh(&lp).0).collect();
    runs.sort_by(|a, b| a.solve.total_cmp(&b.solve));
    let fresh = &runs[runs.len() / 2];
    // The bench's own assembly must be the runtime's problem: same optimum.
    if let Some(cost) = split_cost {
        let gap = (fresh.objective - cost).abs() / cost.abs().max(1e-12);
        assert!(
            gap < 1e-4,
            "direct LP objective {} differs from the runtime's Split cost {cost}",
            fresh.objective
        );
    }
    let per_iteration = fresh.solve / f64::from(fresh.iterations.max(1));
    println!(
        "\n#### {} — Clarabel directly on the Split entropy LP (q = {q}: {} rows, {} columns, nnz(A) = {})\n",
        S::NAME,
        lp.a.m,
        lp.a.n,
        lp.a.nnz()
    );
    println!(
        "setup (presolve, equilibration, KKT assembly, ordering, symbolic) {:.4} s; solve {:.3} s in {} IPM iterations = {:.2} ms each; setup = {:.1}% of setup + solve; nnz(KKT) = {}, nnz(L) = {}",
        fresh.setup,
        fresh.solve,
        fresh.iterations,
        1e3 * per_iteration,
        100.0 * fresh.setup / (fresh.setup + fresh.solve),
        fresh.nnz_kkt,
        fresh.nnz_l
    );

    // Reuse: solver built on batch 1, data of batch 2 swapped in.
    let next = entropy_lp::<S>(&random_batch(data, q, 12), &metric, eta);
    let (_, mut reused) = solve_fresh(&lp);
    let start = Instant::now();
    let update = reused
        .update_A(&next.a.nzval)
        .map_err(|e| format!("{e:?}"))
        .and_then(|()| reused.update_b(&next.b).map_err(|e| format!("{e:?}")));
    let update_seconds = start.elapsed().as_secs_f64();
    match update {
        Ok(()) => {
            let start = Instant::now();
            reused.solve();
            let reuse_solve = start.elapsed().as_secs_f64();
            let (rebuilt, _) = solve_fresh(&next);
            println!(
                "\n| next minibatch | setup / update (s) | solve (s) | IPM iterations | objective |\n|---|---|---|---|---|\n| rebuilt | {:.4} | {:.3} | {} | {:.8e} |\n| reused (update_A, update_b) | {update_seconds:.4} | {reuse_solve:.3} | {} | {:.8e} |",
                rebuilt.setup,
                rebuilt.solve,
                rebuilt.iterations,
                rebuilt.objective,
                reused.solution.iterations,
                reused.solution.obj_val,
            );
        }
        Err(e) => println!("\nsolver reuse refused by Clarabel: {e}"),
    }

    // 5. The floor: dense Aᵀ D A of the LP's shape.
    let r = lp.target.len();
    let a = DMatrix::from_row_slice(r, lp.p, &lp.rows);
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let d: Vec<f64> = (0..r).map(|_| rng.random_range(0.1..10.0)).collect();
    let mut times = Vec::new();
    let mut schur = DMatrix::zeros(lp.p, lp.p);
    for _ in 0..(5 * repeats).max(5) {
        let start = Instant::now();
        let mut da = a.clone();
        for (i, mut row) in da.row_iter_mut().enumerate() {
            row *= d[i];
        }
        schur = a.tr_mul(&da);
        let chol = schur.clone().cholesky();
        std::hint::black_box(&chol);
        times.push(start.elapsed().as_secs_f64());
    }
    std::hint::black_box(&schur);
    let floor = median_of(&mut times);
    let flops = 2.0 * r as f64 * (lp.p * lp.p) as f64;
    println!(
        "\nfloor: dense Aᵀ D A ({r} × {p}) + Cholesky with nalgebra: {:.2} ms ({:.2} GFLOP/s on 2·r·p² = {:.1e} flops); IPM iteration / floor: Clarabel {:.0}×, dense backend {:.1}×",
        1e3 * floor,
        flops / floor / 1e9,
        flops,
        per_iteration / floor,
        dense_per_iteration / floor,
        p = lp.p,
    );

    // Clarabel's own timers for the fresh solve (printed to stdout).
    let (_, solver) = solve_fresh(&lp);
    if let Some(timers) = &solver.timers {
        println!("\nClarabel timers (one fresh solve):\n```");
        timers.print();
        println!("```");
    }
}

/// Peak resident set size of this process so far (VmHWM), in MiB.
fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let flag = |name: &str| args.iter().any(|a| a == name);
    let (quick, peak) = (flag("--quick"), flag("--peak"));
    let iterations = if quick { 1 } else { 2 };
    let repeats = if quick { 1 } else { 3 };
    // With the dense backend q = 8000 costs about a second per iteration.
    let q_list: &[usize] = if quick {
        &[500, 1000, 2000]
    } else {
        &[500, 1000, 2000, 4000, 8000]
    };
    let largest = if peak {
        8000
    } else {
        *q_list.last().unwrap_or(&2000)
    };

    let rigid = rigid_body_data(2 * largest.max(2000), 1);
    if peak {
        let t = median(&time_iterations::<RigidBody>(
            &rigid,
            largest,
            1.0,
            1,
            SolverBackend::Dense,
        ));
        println!(
            "RigidBody q = {largest}: one iteration {:.2} s; peak RSS {:.0} MiB",
            t.wall,
            peak_rss_mib().unwrap_or(f64::NAN)
        );
        return;
    }
    let linear = linear2d_data(3 * 2000, 2);

    if !flag("--solver-only") {
        iteration_sections(&linear, &rigid, q_list, iterations);
        if !quick {
            paper_sized_run(&rigid);
        }
    }

    println!("\n### 3–5. Entropy LP: formulations, setup and reuse, floor\n");
    let target = std::env::var("CARGO_TARGET_DIR").unwrap_or_else(|_| "target".to_owned());
    let dump_path = format!("{target}/bench-data/entropy_lp_rigid_body_q2000.json");
    solver_sections::<Linear2d>(&linear, 2000, repeats, None);
    solver_sections::<RigidBody>(&rigid, 2000, repeats, Some(&dump_path));
}

/// The issue's goal: the paper's SO(3) run (Algorithm 2, 350 iterations at
/// q = 2000, from the paper's initial entropy) end to end.
fn paper_sized_run(rigid: &Dataset) {
    let config = IdentifyConfig {
        batch_size: Some(2000),
        max_iterations: 350,
        tolerance: 0.0,
        seed: 3,
        initial_entropy: Some(perturbed_reference_entropy::<RigidBody>(1.0, 5)),
        ..IdentifyConfig::default()
    };
    let start = Instant::now();
    let result =
        identify_with_observer::<RigidBody, _>(rigid, &config, |_, _| ControlFlow::Continue(()))
            .expect("identification runs");
    let seconds = start.elapsed().as_secs_f64();
    let solver: f64 = result
        .history
        .iterations
        .iter()
        .map(|r| r.metric.report.solver_seconds + r.entropy.report.solver_seconds)
        .sum();
    let cost = model_cost(&result.model, rigid).map_or(f64::NAN, |c| c.per_component);
    println!(
        "\n### Paper-sized SO(3) run (dense backend, Algorithm 2, q = 2000)\n\n{} iterations in {seconds:.1} s ({:.0} ms per iteration, solver {:.0}%); final cost per component on all {} samples {cost:.2e}",
        result.history.iterations.len(),
        1e3 * seconds / result.history.iterations.len().max(1) as f64,
        100.0 * solver / seconds,
        rigid.len(),
    );
}

/// Sections 1 and 2: whole identification iterations.
fn iteration_sections(linear: &Dataset, rigid: &Dataset, q_list: &[usize], iterations: usize) {
    println!("### 1. One iteration at q = 2000 (median of {iterations}; wall = time between observer calls)\n");
    println!("| system, backend | q | wall (s) | assembly (s, %) | solver (s, %) | other (s, %) | assembly + other | IPM iterations metric + entropy |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut walls = Vec::new();
    for backend in [
        SolverBackend::Dense,
        SolverBackend::Clarabel(L1Formulation::default()),
    ] {
        let linear_t = time_iterations::<Linear2d>(linear, 2000, 0.5, iterations, backend);
        let rigid_t = time_iterations::<RigidBody>(rigid, 2000, 1.0, iterations, backend);
        split_row(&format!("Linear2d, {backend:?}"), 2000, &linear_t);
        split_row(&format!("RigidBody, {backend:?}"), 2000, &rigid_t);
        walls.push((median(&linear_t).wall, median(&rigid_t).wall));
    }
    println!(
        "\nClarabel / dense wall time per iteration: Linear2d {:.1}×, RigidBody {:.1}×",
        walls[1].0 / walls[0].0,
        walls[1].1 / walls[0].1
    );

    println!("\n### 2. Scaling (dense backend)\n");
    println!("| system | q | wall (s) | assembly (s, %) | solver (s, %) | other (s, %) | assembly + other | IPM iterations metric + entropy |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut points = Vec::new();
    for &q in q_list {
        // One iteration at the large sizes is enough: they vary least.
        let count = if q > 2000 { 1 } else { iterations };
        let timings = time_iterations::<RigidBody>(rigid, q, 1.0, count, SolverBackend::Dense);
        points.push((q as f64, median(&timings).wall));
        split_row("RigidBody", q, &timings);
    }
    let slope_q = log_log_slope(&points);
    let mut degree_points = Vec::new();
    for (degree, timings, p) in [
        (
            4,
            time_iterations::<RigidBodyDegree4>(rigid, 2000, 1.0, iterations, SolverBackend::Dense),
            RigidBodyDegree4::entropy_coefficient_count(),
        ),
        (
            6,
            time_iterations::<RigidBody>(rigid, 2000, 1.0, iterations, SolverBackend::Dense),
            RigidBody::entropy_coefficient_count(),
        ),
        (
            8,
            time_iterations::<RigidBodyDegree8>(rigid, 2000, 1.0, iterations, SolverBackend::Dense),
            RigidBodyDegree8::entropy_coefficient_count(),
        ),
    ] {
        degree_points.push((p as f64, median(&timings).wall));
        split_row(
            &format!("RigidBody, entropy degree {degree} (p = {p})"),
            2000,
            &timings,
        );
    }
    println!(
        "\nfitted growth: wall ∝ q^{slope_q:.2} (q = {q_list:?}); wall ∝ p^{:.2} over entropy degrees 4, 6, 8 at q = 2000",
        log_log_slope(&degree_points)
    );
    if let Some(mib) = peak_rss_mib() {
        let largest = q_list.last().copied().unwrap_or(2000);
        println!(
            "peak RSS of this process so far (largest q = {largest}{}): {mib:.0} MiB",
            if largest >= 8000 {
                ""
            } else {
                "; run with --peak for q = 8000"
            }
        );
    }
}
