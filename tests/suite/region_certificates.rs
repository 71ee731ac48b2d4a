//! State-dependent metrics certified on a region (`region ball(…)` /
//! `box(…)`): identification from S = 0 recovers the field and K(x), the
//! Gram certificates prove both bounds, the backends agree, model files
//! carry the region, and a metric certified on the region only is accepted
//! there and nowhere else.

use metriplectic::systems::{reference_samples, DragDuffing, DragRigidBody};

use crate::common::exact_dataset;
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    metric_search, simulate, CertificateMode, IdentifyConfig, IdentifyWarning, Method, OutputTimes,
    Region, SearchOptions, SimulationOptions, SolveStatus, SolverBackend, SolverSettings,
};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// States uniform in the ball of `radius` around the origin.
fn in_ball(rng: &mut ChaCha8Rng, n: usize, radius: f64) -> Vec<f64> {
    loop {
        let x: Vec<f64> = (0..n).map(|_| rng.random_range(-radius..radius)).collect();
        if x.iter().map(|v| v * v).sum::<f64>() <= radius * radius {
            return x;
        }
    }
}

fn data<S: MetriplecticSystem>(count: usize, seed: u64, radius: f64) -> Dataset {
    reference_samples::<S>(count, seed, |rng| in_ball(rng, S::DIM, radius))
}

fn eigenvalues<S: MetriplecticSystem>(model: &Model<S>, x: &[f64]) -> Vec<f64> {
    let n = S::DIM;
    let mut k = vec![0.0; n * n];
    model.metric(x, &mut k).unwrap();
    let mut values: Vec<f64> = DMatrix::from_row_slice(n, n, &k)
        .symmetric_eigen()
        .eigenvalues
        .iter()
        .copied()
        .collect();
    values.sort_by(f64::total_cmp);
    values
}

/// (‖f_fit − f‖/‖f‖ over all samples, max ‖K_fit(x) − K(x)‖/‖K(x)‖).
fn errors<S: MetriplecticSystem>(model: &Model<S>, held_out: &Dataset) -> (f64, f64) {
    let truth = Model::<S>::reference().unwrap();
    let n = S::DIM;
    let (mut f, mut g) = (vec![0.0; n], vec![0.0; n]);
    let (mut k, mut l) = (vec![0.0; n * n], vec![0.0; n * n]);
    let (mut diff, mut norm, mut metric) = (0.0, 0.0, 0.0_f64);
    let distance = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    for (x, _) in held_out.iter() {
        model.vector_field(x, &mut f).unwrap();
        truth.vector_field(x, &mut g).unwrap();
        diff += distance(&f, &g).powi(2);
        norm += g.iter().map(|v| v * v).sum::<f64>();
        model.metric(x, &mut k).unwrap();
        truth.metric(x, &mut l).unwrap();
        metric = metric.max(distance(&k, &l) / l.iter().map(|v| v * v).sum::<f64>().sqrt());
    }
    ((diff / norm).sqrt(), metric)
}

/// Identifies `S` from S = 0 on exact data in the ball of `radius` (inside
/// its region), checks the accuracy and the certificate.
fn cold_start<S: MetriplecticSystem>(radius: f64, region_radius: f64) {
    let train = data::<S>(400, 1, radius);
    let held_out = data::<S>(200, 2, radius);
    let config = IdentifyConfig {
        initial_entropy: Some(vec![0.0; S::entropy_coefficient_count()]),
        max_iterations: 150,
        ..IdentifyConfig::default()
    };
    let eta = config.search.eta_for::<S>();
    let run = identify::<S>(&train, &config).unwrap();
    let (field, metric) = errors(&run.model, &held_out);
    let nonoptimal = run
        .history
        .iterations
        .iter()
        .flat_map(|r| {
            [&r.metric, &r.entropy]
                .into_iter()
                .chain(r.joint.as_ref().map(|j| &j.step))
                .map(|step| step.report.status)
        })
        .filter(|s| *s != SolveStatus::Solved)
        .count();
    eprintln!(
        "{}: {} iterations ({:?}), held-out field error {field:.2e}, metric error {metric:.2e}, \
         {nonoptimal} non-optimal solves",
        S::NAME,
        run.history.iterations.len(),
        run.stop_reason
    );
    assert!(field <= 1e-6, "held-out field error {field:e}");
    assert!(metric <= 1e-5, "held-out metric error {metric:e}");
    assert_eq!(nonoptimal, 0, "every solve ends Solved");

    // The certificate kept with the model proves both bounds.
    let certificate = run.model.certificate().expect("a certificate");
    let check = certificate
        .check::<S>(run.model.metric_coefficients())
        .unwrap();
    assert!(check.holds(1e-9), "{check:?}");
    // K(x) ⪰ 0 inside and far outside the region, K(x) ⪯ ηI inside.
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for scale in [0.5, 1.0, 10.0, 1000.0] {
        for _ in 0..200 {
            let x = in_ball(&mut rng, S::DIM, scale * region_radius);
            let values = eigenvalues(&run.model, &x);
            let size = values.iter().fold(1.0_f64, |m, v| m.max(v.abs()));
            assert!(values[0] >= -1e-9 * size, "λmin {} at {x:?}", values[0]);
            if scale <= 1.0 {
                let top = values[S::DIM - 1];
                assert!(eta - top >= -1e-9, "λmax {top} above η = {eta} at {x:?}");
            }
        }
    }
}

#[test]
fn drag_duffing_is_identified_from_a_cold_start() {
    cold_start::<DragDuffing>(2.0, 3.0);
}

#[test]
fn drag_rigid_body_is_identified_from_a_cold_start() {
    cold_start::<DragRigidBody>(1.5, 2.5);
}

metriplectic! {
    /// [`DragDuffing`] with its position a temperature near 300 K
    /// (T = 300 + x) and a drag that grows with it: its monomials of T are
    /// collinear to a few parts in 10⁴ on the ball.
    pub struct DragDuffingNearThreeHundredKelvin;
    state (temp, v);
    const c = 300;
    poisson = [[0, -1], [1, 0]];
    hamiltonian = 0.5 * v^2 + 0.25 * (temp - c)^4 - 0.5 * (temp - c)^2;
    entropy degree 4;
    metric degree 2;
    region ball(center = [300, 0], radius = 3);
    reference {
        entropy = -(v^2 + 0.5 * (temp - c)^4 - (temp - c)^2);
        metric = [[0, 0], [0, 0.1 + 0.2 * v^2 + 0.05 * (temp - c)^2]];
    }
}

/// A region far from the origin: every search used to fail or stall (the
/// held-out field error stagnated at 0.24 from S = 0 and at 4.3e-4 from
/// the default start). The programs now run in coordinates centred on the
/// region (the metric, its certificate) and on the data (the entropy).
///
/// Exact samples are not exact here: the system's own field, evaluated in
/// the monomials of T, differs from the same field written in T − 300 by
/// 7.5e-9 (terms of 0.25·300⁴ cancel to order one). The fit stops at that
/// floor, and the searches near it end `AlmostSolved`, so this test does
/// not ask for every solve to end `Solved` as [`cold_start`] does, and it
/// asks of K what the same system centred at 0 achieves at that floor.
#[test]
fn a_region_far_from_the_origin_is_identified() {
    type S = DragDuffingNearThreeHundredKelvin;
    let around = |count, seed| {
        reference_samples::<S>(count, seed, |rng| {
            let x = in_ball(rng, 2, 2.0);
            vec![300.0 + x[0], x[1]]
        })
    };
    let (train, held_out) = (around(400, 1), around(200, 2));
    for initial_entropy in [None, Some(vec![0.0; S::entropy_coefficient_count()])] {
        let cold = initial_entropy.is_some();
        let config = IdentifyConfig {
            initial_entropy,
            max_iterations: 60,
            ..IdentifyConfig::default()
        };
        let run = identify::<S>(&train, &config).unwrap();
        let (field, metric) = errors(&run.model, &held_out);
        eprintln!(
            "cold start {cold}: {} iterations ({:?}), held-out field error {field:.2e}, metric \
             error {metric:.2e}",
            run.history.iterations.len(),
            run.stop_reason
        );
        assert!(field <= 1e-6, "cold start {cold}: field error {field:e}");
        // K's dependence on T is weakly determined by these data: the same
        // system written in T − 300 gets 1.9e-4 from exact samples and
        // 8.9e-4 with relative noise of 1e-8 on ẋ (the floor above); runs
        // measured 8.4e-4 to 1.1e-3.
        assert!(metric <= 2e-3, "cold start {cold}: metric error {metric:e}");
        // And the run says so: one combination of S and K, a quartic in T
        // with K₁₁'s dependence on T, has singular value 2.3e-9, below the
        // identifiability report's tolerance (1e-8) and the floor of these
        // samples (each block alone is determined at the other's value).
        assert!(
            matches!(
                run.warnings.as_slice(),
                [IdentifyWarning::JointlyUndetermined { directions: 1, .. }]
            ),
            "{:?}",
            run.warnings
        );
        // The kept certificate (over the monomials of T − 300) proves both
        // bounds, and K ⪰ 0 holds on the region and far beyond it.
        let certificate = run.model.certificate().expect("a certificate");
        let check = certificate
            .check::<S>(run.model.metric_coefficients())
            .unwrap();
        assert!(check.holds(1e-9), "{check:?}");
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for scale in [1.0, 100.0] {
            for _ in 0..200 {
                let x = in_ball(&mut rng, 2, scale * 3.0);
                let x = [300.0 + x[0], x[1]];
                let values = eigenvalues(&run.model, &x);
                let size = values.iter().fold(1.0_f64, |m, v| m.max(v.abs()));
                assert!(values[0] >= -1e-9 * size, "λmin {} at {x:?}", values[0]);
            }
        }
    }
}

#[test]
fn the_region_and_mode_come_from_the_declaration() {
    let certificate = DragDuffing::REGION_CERTIFICATE.expect("a region");
    assert_eq!(
        certificate.region,
        Region::Ball {
            center: &[0.0, 0.0],
            radius: 3.0
        }
    );
    assert_eq!(certificate.mode, CertificateMode::GlobalLowerBound);
    assert!(certificate.region.contains(&[2.0, 2.0]));
    assert!(!certificate.region.contains(&[2.2, 2.2]));
}

/// The dense backend reaches Clarabel's optimum on the region program, off
/// the truth so that the optimum is not zero.
#[test]
fn backends_agree_on_the_region_program() {
    let data = data::<DragRigidBody>(300, 4, 1.5);
    let mut entropy = DragRigidBody::REFERENCE_ENTROPY.unwrap().to_vec();
    entropy.iter_mut().step_by(3).for_each(|c| *c += 0.2);
    let fit = |backend| {
        let options = SearchOptions {
            solver: SolverSettings {
                backend,
                ..SolverSettings::default()
            },
            ..SearchOptions::default()
        };
        metric_search::<DragRigidBody>(&data, &entropy, &options).unwrap()
    };
    let dense = fit(SolverBackend::Dense);
    let clarabel = fit(SolverBackend::Clarabel(Default::default()));
    // Clarabel ends at its feasibility tolerance, 1e-8 (its upper
    // identities of degree-4 targets are off by 2.7e-9 in the region's
    // unit-scaled states, where the check weighs them by ρ⁴ = 39); the
    // dense backend's refinement takes them to 6e-13.
    for (search, tolerance) in [(&dense, 1e-9), (&clarabel, 1e-8)] {
        assert_eq!(search.report.status, SolveStatus::Solved);
        let check = search
            .certificate
            .check::<DragRigidBody>(&search.coefficients)
            .unwrap();
        assert!(check.holds(tolerance), "{check:?}");
    }
    let (a, b) = (
        dense.report.cost.unwrap().sum,
        clarabel.report.cost.unwrap().sum,
    );
    assert!(a > 1e-3);
    assert!((a - b).abs() <= 1e-6 * b, "dense {a} vs Clarabel {b}");
}

#[test]
fn model_files_carry_the_region_mode_and_certificate() {
    let data = data::<DragDuffing>(200, 5, 2.0);
    let entropy = DragDuffing::REFERENCE_ENTROPY.unwrap();
    let search = metric_search::<DragDuffing>(&data, entropy, &SearchOptions::default()).unwrap();
    let model = Model::<DragDuffing>::new(entropy.to_vec(), search.coefficients)
        .unwrap()
        .with_certificate(search.certificate)
        .unwrap();
    let json = model.to_json().unwrap();
    for needle in [
        "\"region\"",
        "\"ball\"",
        "GlobalLowerBound",
        "for every state",
        "\"certificate\"",
    ] {
        assert!(json.contains(needle), "no {needle} in {json}");
    }
    let loaded = Model::<DragDuffing>::from_json(&json).unwrap();
    assert_eq!(loaded, model);
    assert_eq!(loaded.certificate(), model.certificate());

    // Another region is another system.
    let moved = json.replace("\"radius\": 3.0", "\"radius\": 4.0");
    assert_ne!(moved, json);
    let error = Model::<DragDuffing>::from_json(&moved).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("different certificate region or mode"),
        "{error}"
    );
    // The text derived from them, edited alone, is named as such.
    let reworded = json.replace("for every state", "for some states");
    assert_ne!(reworded, json);
    let error = Model::<DragDuffing>::from_json(&reworded).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("whose `free_energy_certified` text was edited"),
        "{error}"
    );
    // A certificate with the wrong shape is refused, naming the block.
    let mut value: serde_json::Value = serde_json::from_str(&json).unwrap();
    value["certificate"]["lower"][0]["size"] = 2.into();
    let error = Model::<DragDuffing>::from_json(&value.to_string()).unwrap_err();
    assert!(error.to_string().contains("lower block 1"), "{error}");

    // A certificate of the right shape that proves nothing (its Gram
    // matrices negated, or kept beside a metric edited to twice its value)
    // is refused too: it loaded before, a false proof kept with the model.
    let mut negated: serde_json::Value = serde_json::from_str(&json).unwrap();
    for block in negated["certificate"]["lower"].as_array_mut().unwrap() {
        for v in block["values"].as_array_mut().unwrap() {
            *v = (-v.as_f64().unwrap()).into();
        }
    }
    let mut stale: serde_json::Value = serde_json::from_str(&json).unwrap();
    for v in stale["metric"].as_array_mut().unwrap() {
        *v = (2.0 * v.as_f64().unwrap()).into();
    }
    for edited in [negated, stale] {
        let error = Model::<DragDuffing>::from_json(&edited.to_string()).unwrap_err();
        assert!(
            error.to_string().contains("does not prove this metric"),
            "{error}"
        );
    }
}

metriplectic! {
    /// K(q) = 1 − q² is PSD on the box, not beyond it.
    struct OnTheBoxOnly;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * (q^2 + p^2);
    entropy degree 2;
    metric degree 2;
    region box(q in [-0.5, 0.5], p in [-1, 1]);
    certificate on region;
}

metriplectic! {
    /// The same with the default mode: K(x) ⪰ 0 everywhere.
    struct Everywhere;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * (q^2 + p^2);
    entropy degree 2;
    metric degree 2;
    region box(q in [-0.5, 0.5], p in [-1, 1]);
}

/// ψ of S = −(q² + p²): with H = (q² + p²)/2, E = −(q² + p²)/2, so the
/// flow spirals in.
fn spiral_entropy<S: MetriplecticSystem>() -> Vec<f64> {
    let mut entropy = vec![0.0; S::entropy_coefficient_count()];
    for square in [[2, 0], [0, 2]] {
        let k = S::ENTROPY_EXPONENTS
            .iter()
            .position(|e| e == &square)
            .unwrap();
        entropy[k] = -1.0;
    }
    entropy
}

/// θ of K = diag(1 − c·q², 1).
fn shrinking_metric<S: MetriplecticSystem>(c: f64) -> Vec<f64> {
    shrinking_metric_around::<S>(c, 0.0)
}

/// θ of K = diag(1 − c·(q − q₀)², 1), expanded in q.
fn shrinking_metric_around<S: MetriplecticSystem>(c: f64, q0: f64) -> Vec<f64> {
    let basis = S::METRIC_EXPONENTS.len();
    let mut theta = vec![0.0; S::metric_coefficient_count()];
    let position = |exponent: [u32; 2]| {
        S::METRIC_EXPONENTS
            .iter()
            .position(|e| e == &exponent)
            .unwrap()
    };
    theta[0] = 1.0 - c * q0 * q0;
    theta[position([1, 0])] = 2.0 * c * q0;
    theta[position([2, 0])] = -c;
    theta[2 * basis] = 1.0;
    theta
}

#[test]
fn a_metric_certified_on_the_region_only_is_accepted_there_only() {
    let entropy = vec![0.0; 5];
    // 1 − q² ≥ 0.75 on the box: accepted when the region is all that counts.
    let model =
        Model::<OnTheBoxOnly>::new(entropy.clone(), shrinking_metric::<OnTheBoxOnly>(1.0)).unwrap();
    assert!(model
        .to_json()
        .unwrap()
        .contains("only for states in the region"));
    // …but not where dE/dt ≥ 0 is promised for every state.
    let error =
        Model::<Everywhere>::new(entropy.clone(), shrinking_metric::<Everywhere>(1.0)).unwrap_err();
    assert!(
        matches!(
            error,
            Error::MetricNotPositive { .. } | Error::MetricNotCertified { .. }
        ),
        "{error}"
    );
    // A witness outside the region would puzzle: the error says why it counts.
    assert!(
        error
            .to_string()
            .contains("unless the system declares `certificate on region;`"),
        "{error}"
    );
    // A witness inside the region needs no word about outside it.
    let error =
        Model::<Everywhere>::new(entropy.clone(), shrinking_metric::<Everywhere>(8.0)).unwrap_err();
    match &error {
        Error::MetricNotPositive {
            state: Some(x),
            what,
            ..
        } if x[0].abs() <= 0.5 && x[1].abs() <= 1.0 => {
            assert!(!what.contains("outside the region too"), "{error}")
        }
        other => panic!("expected a witness in the box: {other}"),
    }
    // A constant indefinite metric is indefinite everywhere: no state named.
    let mut constant = vec![0.0; OnTheBoxOnly::metric_coefficient_count()];
    constant[0] = -1.0;
    constant[2 * OnTheBoxOnly::METRIC_EXPONENTS.len()] = 1.0;
    match Model::<OnTheBoxOnly>::new(entropy.clone(), constant).unwrap_err() {
        Error::MetricNotPositive { state: None, .. } => {}
        other => panic!("{other}"),
    }
    // 1 − 8q² < 0 at q = ±0.5: refused on the region too, with a state inside it.
    match Model::<OnTheBoxOnly>::new(entropy, shrinking_metric::<OnTheBoxOnly>(8.0)).unwrap_err() {
        Error::MetricNotPositive {
            eigenvalue,
            state: Some(x),
            ..
        } => {
            assert!(eigenvalue < 0.0);
            assert!(x[0].abs() <= 0.5 && x[1].abs() <= 1.0, "{x:?}");
        }
        other => panic!("{other}"),
    }
}

#[test]
fn the_region_check_does_not_depend_on_the_metric_scale() {
    let entropy = vec![0.0; 5];
    let scaled = |c: f64, factor: f64| -> Vec<f64> {
        shrinking_metric::<OnTheBoxOnly>(c)
            .into_iter()
            .map(|t| t * factor)
            .collect()
    };
    for factor in [1e-10, 1e-6, 1e6] {
        // 1 − 8q² < 0 at q = ±0.5 whatever the factor: a metric this small
        // is still indefinite, and must not pass on the solver's absolute
        // tolerances.
        let error = Model::<OnTheBoxOnly>::new(entropy.clone(), scaled(8.0, factor)).unwrap_err();
        assert!(
            matches!(
                error,
                Error::MetricNotPositive { .. } | Error::MetricNotCertified { .. }
            ),
            "factor {factor}: {error}"
        );
        // 1 − q² ≥ 0.75 on the box: accepted at every scale.
        Model::<OnTheBoxOnly>::new(entropy.clone(), scaled(1.0, factor))
            .unwrap_or_else(|e| panic!("factor {factor}: {e}"));
    }
}

/// Nor on the scales of its axes: an entry of 1e12 beside one of 1 leaves
/// a direction negative at 0.96·|∇E|², 1e-12 of the largest coefficient
/// (accepted before the axes were balanced), while the same scales with a
/// positive semidefinite metric pass.
#[test]
fn the_region_check_does_not_depend_on_the_scales_of_the_axes() {
    let entropy = vec![0.0; 5];
    let basis = OnTheBoxOnly::METRIC_EXPONENTS.len();
    // K = [[1e12 − q², c], [c, 1]]; θ's pairs (0,0), (0,1), (1,1).
    let metric = |c: f64| {
        let mut theta = vec![0.0; OnTheBoxOnly::metric_coefficient_count()];
        theta[0] = 1e12;
        theta[3] = -1.0;
        theta[basis] = c;
        theta[2 * basis] = 1.0;
        theta
    };
    match Model::<OnTheBoxOnly>::new(entropy.clone(), metric(1.4e6)).unwrap_err() {
        Error::MetricNotPositive {
            eigenvalue,
            state: Some(x),
            ..
        } => {
            assert!(eigenvalue < -0.5, "{eigenvalue}");
            assert!(x[0].abs() <= 0.5 && x[1].abs() <= 1.0, "{x:?}");
        }
        other => panic!("{other}"),
    }
    // Determinant 1e12 − q² − 0.998e12 > 0 on the box.
    Model::<OnTheBoxOnly>::new(entropy, metric(0.999e6)).unwrap();
}

metriplectic! {
    /// [`OnTheBoxOnly`] with q in millimetres: K(q) = 1 − c·q² on
    /// |q| ≤ 500.
    struct OnTheBoxInMillimetres;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * (q^2 + p^2);
    entropy degree 2;
    metric degree 2;
    region box(q in [-500, 500], p in [-1, 1]);
    certificate on region;
}

metriplectic! {
    /// [`OnTheBoxOnly`] with q in kilometres: |q| ≤ 0.0005.
    struct OnTheBoxInKilometres;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * (q^2 + p^2);
    entropy degree 2;
    metric degree 2;
    region box(q in [-0.0005, 0.0005], p in [-1, 1]);
    certificate on region;
}

/// K = 1 − c·(q − q₀)² on |q − q₀| ≤ `edge` is PSD there for c up to
/// 1/edge²: accepted just below that, refused just above it.
fn region_check_at_the_edge<S: MetriplecticSystem>(edge: f64, q0: f64) {
    let entropy = vec![0.0; 5];
    let boundary = 1.0 / (edge * edge);
    for factor in [0.25, 0.9975, 0.99975] {
        let c = factor * boundary;
        Model::<S>::new(entropy.clone(), shrinking_metric_around::<S>(c, q0))
            .unwrap_or_else(|e| panic!("c = {c}: {e}"));
    }
    // K(q₀ ± edge) = −2.5e-4, −2.5e-3, −7.
    for factor in [1.00025, 1.0025, 8.0] {
        let c = factor * boundary;
        match Model::<S>::new(entropy.clone(), shrinking_metric_around::<S>(c, q0)) {
            Err(Error::MetricNotPositive { .. }) => {}
            // Just past the edge no state is named; the message says where
            // K ⪰ 0 is required (it used to say "for every x" here too).
            Err(error @ Error::MetricNotCertified { .. }) => {
                let message = error.to_string();
                assert!(message.contains("on the region only"), "{message}");
                assert!(!message.contains("for every x"), "{message}");
            }
            other => panic!("c = {c}: {other:?}"),
        }
    }
}

/// The region check decides by the metric on the region, not by the size of
/// its coefficients or its region: the line between PSD on the box and not
/// is where it is in metres. It used to accept K(±500) = −2.5e-4 in
/// millimetres and K(±0.0005) = −0.025 in kilometres: its tolerance allowed
/// K(x) ⪰ −1e-8·max|θ|·‖Z(x)‖², and ‖Z(x)‖² is 2.5e5 at the edge of the
/// first box, max|θ| = 4e6 in the second.
#[test]
fn the_region_check_does_not_depend_on_the_units() {
    region_check_at_the_edge::<OnTheBoxInMillimetres>(500.0, 0.0);
    region_check_at_the_edge::<OnTheBoxInKilometres>(0.0005, 0.0);
    region_check_at_the_edge::<OnTheBoxOnly>(0.5, 0.0);
}

metriplectic! {
    /// [`OnTheBoxOnly`] moved to q ∈ [299.5, 300.5], a box far from the
    /// origin against its width.
    struct OnTheBoxNearThreeHundred;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * (q^2 + p^2);
    entropy degree 2;
    metric degree 2;
    region box(q in [299.5, 300.5], p in [-1, 1]);
    certificate on region;
}

/// Nor by where the region lies: on a box far from the origin the
/// certificate is set up in coordinates centred on it, where K's
/// coefficients are those of 1 − c·(q − 300)² and not of the expanded
/// 1 − 9e4·c + 600c·q − c·q².
#[test]
fn the_region_check_does_not_depend_on_where_the_region_lies() {
    region_check_at_the_edge::<OnTheBoxNearThreeHundred>(0.5, 300.0);
}

metriplectic! {
    /// [`DragDuffing`] with its states in millimetres (x′ = 1000x): the
    /// same flow, H and K with coefficients of 1e-7 beside ones of order one,
    /// and a ball of radius 3000.
    pub struct DragDuffingInMillimetres;
    state (x, v);
    const s = 1000;
    poisson = [[0, -1], [1, 0]];
    hamiltonian = 0.5 * v^2 + 0.25 * x^4 / s^2 - 0.5 * x^2;
    entropy degree 4;
    metric degree 2;
    region ball(radius = 3000);
    reference {
        entropy = -(v^2 + 0.5 * x^4 / s^2 - x^2);
        metric = [[0, 0], [0, 0.1 + 0.2 * v^2 / s^2]];
    }
}

/// A region certificate in other units identifies as in unit scale: every
/// metric search used to fail in millimetres (held-out error 0.4, K off by
/// 68 times its size), since the Gram entries spanned twelve orders of
/// magnitude. The programs now run in the region's unit-scaled states.
#[test]
fn a_region_in_millimetres_is_identified_from_a_cold_start() {
    cold_start::<DragDuffingInMillimetres>(2000.0, 3000.0);
}

/// Data outside the region of `certificate on region` are where nothing
/// proves dE/dt ≥ 0: the identification says how many there are (a probe's
/// data centred far outside the ball came back with no warning).
#[test]
fn data_outside_an_on_region_certificate_are_a_warning() {
    let truth = Model::<OnTheBoxOnly>::new(
        spiral_entropy::<OnTheBoxOnly>(),
        shrinking_metric::<OnTheBoxOnly>(1.0),
    )
    .unwrap();
    // 40 states in the box, 10 beyond it in q (where 1 − q² is still positive).
    let states: Vec<[f64; 2]> = (0..50)
        .map(|i| {
            let t = i as f64 / 50.0;
            let q = if i < 40 {
                -0.45 + 0.9 * t * 1.25
            } else {
                0.6 + 0.3 * (t - 0.8) * 5.0
            };
            [q, (7.0 * t).sin()]
        })
        .collect();
    let data = exact_dataset(&truth, &states);
    let fit = identify::<OnTheBoxOnly>(&data, &IdentifyConfig::default()).unwrap();
    assert!(
        fit.warnings.contains(&IdentifyWarning::DataOutsideRegion {
            outside: 10,
            states: 50
        }),
        "{:?}",
        fit.warnings
    );
    let text = fit
        .warnings
        .iter()
        .map(ToString::to_string)
        .collect::<String>();
    assert!(text.contains("10 of the 50 data states"), "{text}");

    // Inside the box only: no such warning.
    let inside = exact_dataset(&truth, &states[..40]);
    let fit = identify::<OnTheBoxOnly>(&inside, &IdentifyConfig::default()).unwrap();
    assert!(
        !fit.warnings
            .iter()
            .any(|w| matches!(w, IdentifyWarning::DataOutsideRegion { .. })),
        "{:?}",
        fit.warnings
    );
}

/// A simulation that leaves the region of `certificate on region` runs
/// where nothing proves dE/dt ≥ 0: it says which outputs lie outside (a
/// probe's simulation from outside the region came back with energy-check
/// violations and no word about the region).
#[test]
fn a_simulation_outside_an_on_region_certificate_says_so() {
    // E = −(q² + p²)/2: the flow spirals in, so a start in the box stays there.
    let model = Model::<OnTheBoxOnly>::new(
        spiral_entropy::<OnTheBoxOnly>(),
        shrinking_metric::<OnTheBoxOnly>(1.0),
    )
    .unwrap();
    let options = SimulationOptions::default();
    let inside = simulate(&model, &[0.3, 0.0], 0.0, 5.0, &options).unwrap();
    assert_eq!(inside.outside_region, None);
    // From p = 1.5 (outside the box) the spiral swings out to |q| > 0.5
    // before it enters the box.
    let outside = simulate(&model, &[0.0, 1.5], 0.0, 20.0, &options).unwrap();
    let count = outside
        .trajectory
        .states()
        .chunks_exact(2)
        .filter(|x| x[0].abs() > 0.5 || x[1].abs() > 1.0)
        .count();
    assert!(count > 0 && count < outside.trajectory.len());
    let reported = outside.outside_region.unwrap();
    assert_eq!(reported.outputs, count);
    assert_eq!(reported.first_time, 0.0);
    assert!(reported.steps > 0 && reported.steps < outside.stats.accepted_steps as usize);
    // Outputs only at the ends, both inside: from (−0.49, 0.99) the spiral
    // swings out to |q| ≈ 0.63 between them, and the report says so (a probe's run reported
    // nothing while E fell between its two outputs).
    let ends = SimulationOptions {
        output: OutputTimes::Times(vec![0.0, 20.0]),
        ..SimulationOptions::default()
    };
    for method in [Method::Dopri5, Method::DiscreteGradient { step: 0.05 }] {
        let run = simulate(
            &model,
            &[-0.49, 0.99],
            0.0,
            20.0,
            &SimulationOptions {
                method,
                ..ends.clone()
            },
        )
        .unwrap();
        let x = run.trajectory.states();
        assert!(x
            .chunks_exact(2)
            .all(|x| x[0].abs() <= 0.5 && x[1].abs() <= 1.0));
        let reported = run
            .outside_region
            .unwrap_or_else(|| panic!("{method:?}: nothing reported"));
        assert_eq!(reported.outputs, 0, "{method:?}");
        assert!(reported.steps > 0, "{method:?}");
        assert!(
            reported.first_time > 0.0 && reported.first_time < 20.0,
            "{method:?}"
        );
    }
    // The default mode proves K ⪰ 0 everywhere: nothing to report.
    let entropy = spiral_entropy::<Everywhere>();
    let metric = {
        let mut theta = vec![0.0; Everywhere::metric_coefficient_count()];
        theta[0] = 1.0;
        theta[2 * Everywhere::METRIC_EXPONENTS.len()] = 1.0;
        theta
    };
    let everywhere = Model::<Everywhere>::new(entropy, metric).unwrap();
    let run = simulate(&everywhere, &[0.0, 1.5], 0.0, 5.0, &options).unwrap();
    assert_eq!(run.outside_region, None);
}
