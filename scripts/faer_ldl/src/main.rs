//! Solves one dumped LP with Clarabel's QDLDL and with its faer LDL, a few
//! times each, and prints setup time, solve time, iterations and time per
//! interior-point iteration. Usage: `faer_ldl PROBLEM.json [REPEATS]`.

use std::time::Instant;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SupportedConeT};
use serde::Deserialize;

/// An LP min qᵀx s.t. Ax + s = b, s in zero/nonnegative cones, in CSC form.
#[derive(Deserialize)]
struct Problem {
    m: usize,
    n: usize,
    colptr: Vec<usize>,
    rowval: Vec<usize>,
    nzval: Vec<f64>,
    q: Vec<f64>,
    b: Vec<f64>,
    /// ("zero" | "nonneg", dimension) in row order.
    cones: Vec<(String, usize)>,
}

fn main() {
    let mut args = std::env::args().skip(1);
    let path = args.next().expect("usage: faer_ldl PROBLEM.json [REPEATS]");
    let repeats: usize = args
        .next()
        .map_or(3, |r| r.parse().expect("REPEATS is a number"));
    let text = std::fs::read_to_string(&path).expect("readable problem file");
    let problem: Problem = serde_json::from_str(&text).expect("problem JSON");
    let a = CscMatrix::new(
        problem.m,
        problem.n,
        problem.colptr,
        problem.rowval,
        problem.nzval,
    );
    let cones: Vec<SupportedConeT<f64>> = problem
        .cones
        .iter()
        .map(|(kind, dim)| match kind.as_str() {
            "zero" => SupportedConeT::ZeroConeT(*dim),
            "nonneg" => SupportedConeT::NonnegativeConeT(*dim),
            other => panic!("unknown cone {other}"),
        })
        .collect();
    let p = CscMatrix::zeros((problem.n, problem.n));
    println!(
        "problem {path}: {} rows, {} columns, {} nonzeros",
        problem.m,
        problem.n,
        a.nnz()
    );
    println!("| LDL | setup (s) | solve (s) | IPM iterations | per iteration (ms) | objective | status |");
    println!("|---|---|---|---|---|---|---|");
    // max_threads 0 lets faer choose (it may use both cores); QDLDL is serial.
    // Interleaved (method inside repeat) so that machine noise hits all alike.
    for _ in 0..repeats {
        for (method, threads) in [("qdldl", 0), ("faer", 1), ("faer", 0)] {
            let settings = DefaultSettings {
                verbose: false,
                direct_solve_method: method.to_owned(),
                max_threads: threads,
                ..DefaultSettings::default()
            };
            let start = Instant::now();
            let mut solver = DefaultSolver::new(&p, &problem.q, &a, &problem.b, &cones, settings)
                .expect("valid problem");
            let setup = start.elapsed().as_secs_f64();
            let start = Instant::now();
            solver.solve();
            let solve = start.elapsed().as_secs_f64();
            let iterations = solver.solution.iterations;
            println!(
                "| {method} (threads {threads}) | {setup:.4} | {solve:.4} | {iterations} | {:.2} | {:.10e} | {:?} |",
                1e3 * solve / f64::from(iterations.max(1)),
                solver.solution.obj_val,
                solver.solution.status
            );
        }
    }
}
