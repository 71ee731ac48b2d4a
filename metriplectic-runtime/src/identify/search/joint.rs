//! A joint, linearised step in both coefficient blocks (ψ, θ) at once: a
//! Gauss–Newton step for the L1 cost, in a trust region.

use super::centre::{centred_entropy_regression, centred_metric_regression, entropy_shift};
use super::sos::{add_metric_restrictions, add_sos_constraints, layout, SosConstraints};
use super::{entropy_regression, metric_regression, SearchOptions, SearchReport};
use crate::data::check_dataset;
use crate::data::IdentificationData;
use crate::error::{invalid, Result};
use crate::identify::cost::{model_cost, model_residuals, Cost};
use crate::model::classical::{self, Equalities};
use crate::model::{theta_from_gram, GramCertificate, Model, Shift, MAX_COEFFICIENT};
use crate::solve::{solve_l1, Cone, L1Problem, Regression};
use crate::system::MetriplecticSystem;

/// Weight of the joint step's L1 proximal term relative to each
/// coefficient column's L1 norm (see the module docs): directions along
/// which the linearised data cost changes more slowly than this fraction of
/// its largest possible rate count as flat and are not moved along.
const STEP_PENALTY: f64 = 1e-6;

/// The result of one joint step.
#[derive(Debug, Clone, PartialEq)]
pub struct JointStep {
    /// Candidate entropy coefficients ψ + d (clipped to [−η, η]).
    pub entropy: Vec<f64>,
    /// Candidate metric coefficients θ′, recomputed from the lower Gram
    /// matrices as in the metric search (so K ⪰ 0 holds exactly).
    pub metric: Vec<f64>,
    /// The Gram matrices proving the candidate metric's bounds.
    pub certificate: GramCertificate,
    /// The linearised cost at the solver's point (what the step predicts);
    /// `None` if the solver returned non-finite values.
    pub predicted: Option<Cost>,
    /// Status, timings and the candidate's true (recomputed) cost.
    pub report: SearchReport,
}

/// One joint linearised step from `model` on `data` with trust radius
/// `radius`: coefficient k moves by at most `radius` times its width, the
/// larger of its own size and ‖t‖₁/‖Aₖ‖₁, the size it would need to account
/// alone for the current residual — so that the radius means the same in
/// any units. For states or a region far from the origin, the coefficients
/// are those of the centred coordinates the step works in (the box
/// |ψ + d| ≤ η stays on the coefficients in x; `docs/method.md` §2).
///
/// Errors on invalid input; solver trouble is reported in the status.
///
/// The alternating searches minimise the bilinear cost exactly in one block
/// at a time. On the nonsmooth L1 cost such block-coordinate descent can
/// crawl along valleys that are not aligned with either block (each block
/// is optimal, the pair is not jointly stationary). This step moves both
/// blocks together. At the current (ψ, θ), with g = ∇H + ∇S(ψ),
/// M = Π + K(θ) and J the Jacobian of the entropy features, the residual of
/// sample i at (ψ + d, θ′) is
///
/// ```text
/// rᵢ = ẋᵢ − Πᵢ gᵢ − K(xᵢ; θ′) gᵢ − Mᵢ Jᵢᵀ d  −  (K(xᵢ; θ′) − K(xᵢ; θ)) Jᵢᵀ d,
/// ```
///
/// linear in (θ′, d) but for the last, bilinear, term. Dropping it leaves
/// one convex program, solved exactly like the metric search (same L1
/// objective, same SOS cones on θ′) with the entropy columns
/// [`entropy_block`](crate::MetriplecticSystem::entropy_block) added
/// beside the [`metric_block`](crate::MetriplecticSystem::metric_block)
/// columns, plus the trust region |d|∞ ≤ Δ, |θ′ − θ|∞ ≤ Δ and the box
/// |ψ + d| ≤ η. The current point is feasible, so the linearised cost never
/// exceeds the current cost; the true cost of the candidate is recomputed
/// and the caller accepts it only if it did not increase (Theorem 1).
/// For a zero-residual problem such steps converge fast near the solution,
/// where the dropped term is second order.
///
/// # Flat directions and the step penalty
///
/// The bilinear cost can have exact symmetries. On the SO(3) rigid body
/// (Π∇E = 0) the residual ẋ − (Π + K)∇E is unchanged by (K, E) ↦ (cK, E/c),
/// so the linearised program is flat along (δK ∝ K, δE ∝ −E): measured on
/// the paper's run, the smallest singular value of its free columns was
/// 1.5·10⁻⁷ against 0.36 for the next. Only the far-away trust-region rows
/// bound that direction, so near the exact fit the interior-point Newton
/// system becomes numerically singular (Clarabel's LDLᵀ needed dynamic
/// regularisation, the solve went non-finite, and the run ended
/// `AlmostSolved`), and the step could wander along the symmetry, where
/// the dropped bilinear term makes the true cost worse than predicted.
/// Every joint step therefore adds a small L1 proximal term
/// Σₖ λₖ |Δₖ| on the coefficient changes (extra regression rows with zero
/// target), with λₖ = `STEP_PENALTY` · Σᵢ |Aᵢₖ| relative to the rate at
/// which the data term can change along coefficient k. Polyhedral penalties
/// are exact: directions along which the data term rises faster than the
/// penalty keep their unpenalised optimum, while (nearly) flat directions
/// get the shortest step. The predicted cost excludes the penalty.
pub fn joint_step<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    model: &Model<S>,
    radius: f64,
    options: &SearchOptions,
) -> Result<JointStep> {
    step_with_offset::<S>(data, model, radius, options, None)
}

/// The joint step from `model` again, with the second-order correction
/// taken from its first candidate `trial`: `None` if `trial` is no valid
/// model or its residuals on `data` are not finite (then there is nothing
/// to correct with).
///
/// The linearised residual r̃ᵢ(θ′, d) misses the bilinear term
/// Bᵢ = (K(xᵢ; θ′) − K(xᵢ; θ)) Jᵢᵀ d. At the trial point (θ′₁, d₁) it is
/// known exactly, as the linearised residual minus the true one, and the
/// corrected program fits r̃ᵢ(θ′, d) − Bᵢ(θ′₁, d₁): the same program with
/// each data row's target shifted, whose residual equals the true one at
/// the trial point. This is the second-order correction of sequential
/// linear programming for nonsmooth penalties (Fletcher 1982; the remedy
/// for the Maratos effect): near an exact fit, the residuals that vanish
/// at the solution form a curved set, a linear step leaves it by O(|d|²),
/// and the trust region shrinks until that loss is small against the
/// step's gain; the corrected step follows the set to O(|d|³).
pub(crate) fn corrected_joint_step<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    model: &Model<S>,
    radius: f64,
    options: &SearchOptions,
    trial: &JointStep,
) -> Result<Option<JointStep>> {
    let Ok(candidate) = Model::<S>::new(trial.entropy.clone(), trial.metric.clone()) else {
        return Ok(None);
    };
    let true_residuals = model_residuals(&candidate, data)?;
    // A candidate whose field overflows on the data gives no usable shift.
    if !true_residuals.iter().all(|r| r.is_finite()) {
        return Ok(None);
    }
    let offset = Offset {
        true_residuals,
        metric: &trial.metric,
        entropy: &trial.entropy,
    };
    step_with_offset::<S>(data, model, radius, options, Some(offset)).map(Some)
}

/// A trial point of the joint step and its true residuals, row by row: what
/// [`corrected_joint_step`] shifts the targets by.
struct Offset<'a> {
    true_residuals: Vec<f64>,
    metric: &'a [f64],
    entropy: &'a [f64],
}

impl Offset<'_> {
    /// Shifts `regression`'s targets by the bilinear term at the trial
    /// point, the linearised residual there minus the true one; `psi` is the
    /// current entropy on the free coefficients `free`.
    /// With `metric_shift` and `entropy_shift`, the columns are those of
    /// the centred coordinates.
    fn apply(
        &self,
        regression: &mut Regression,
        free: &[usize],
        psi: &[f64],
        metric_shift: Option<&Shift>,
        entropy_shift: Option<&Shift>,
    ) {
        let entropy_step: Vec<f64> = free
            .iter()
            .zip(psi)
            .map(|(&k, v)| self.entropy[k] - v)
            .collect();
        let entropy_step = match entropy_shift {
            Some(shift) => shift.to_centred(&entropy_step),
            None => entropy_step,
        };
        let metric = match metric_shift {
            Some(shift) => shift.to_centred(self.metric),
            None => self.metric.to_vec(),
        };
        let step: Vec<f64> = metric.into_iter().chain(entropy_step).collect();
        let width = regression.width;
        for ((target, row), truth) in regression
            .target
            .iter_mut()
            .zip(regression.rows.chunks_exact(width))
            .zip(&self.true_residuals)
        {
            let linearised = *target - row.iter().zip(&step).map(|(a, z)| a * z).sum::<f64>();
            let shifted = *target - (linearised - truth);
            // A row whose shift overflows keeps its first-order target.
            if shifted.is_finite() {
                *target = shifted;
            }
        }
    }
}

/// [`joint_step`], its data rows' targets shifted by `offset` if given.
fn step_with_offset<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    model: &Model<S>,
    radius: f64,
    options: &SearchOptions,
    offset: Option<Offset<'_>>,
) -> Result<JointStep> {
    check_dataset::<S>(data)?;
    options.validate_for::<S>()?;
    let eta = options.eta_for::<S>();
    if !(radius.is_finite() && radius > 0.0) {
        return Err(invalid(
            "trust radius",
            format!("{radius} is not a finite positive number"),
        ));
    }
    let layout = layout::<S>(options.sos)?;
    let theta = model.metric_coefficients();
    // θ′'s columns are in the layout's coordinates (centred for a region
    // far from the origin), and so are its trust region and penalty.
    let searched_theta = layout.centred_metric(theta);
    // Entropy coefficients outside the support are neither columns nor moved.
    let free = options.support.free_entropy::<S>();
    let all_psi = model.entropy_coefficients();
    let psi: Vec<f64> = free.iter().map(|&k| all_psi[k]).collect();
    let (t_len, p) = (theta.len(), psi.len());

    let start = std::time::Instant::now();
    // Columns [θ′ | d]; the metric regression's target ẋ − Π g is the
    // residual's constant part.
    // One copy of the data's rows at a time: at q = 16000 samples of a
    // 6-state system with 923 entropy coefficients each takes 725 MB.
    // States far from the origin move ψ in centred coordinates.
    let centre = entropy_shift::<S>(data, &free);
    let mut regression = {
        let mut entropy_columns = match &centre {
            Some(shift) => centred_entropy_regression::<S>(shift, data, theta)?,
            None => entropy_regression::<S>(data, theta)?,
        };
        if p < all_psi.len() {
            entropy_columns = entropy_columns.select_columns(&free);
        }
        let metric_columns = match layout.shift() {
            Some(shift) => centred_metric_regression::<S>(shift, data, all_psi)?,
            None => metric_regression::<S>(data, all_psi)?,
        };
        metric_columns.with_columns_of(&entropy_columns)
    };
    // The trust region in units of each coefficient's effect on the data,
    // the same for the corrected step as for the first.
    let searched_psi = match &centre {
        Some(centre) => centre.to_centred(&psi),
        None => psi.clone(),
    };
    let widths = trust_widths(&regression, &searched_theta, &searched_psi);
    if let Some(offset) = &offset {
        offset.apply(
            &mut regression,
            &free,
            &psi,
            layout.shift(),
            centre.as_ref(),
        );
    }
    let data_rows = regression.len();
    let penalty = step_penalty(&regression, &searched_theta);
    let mut problem = L1Problem::new(
        regression.stacked(&penalty),
        SosConstraints::variables::<S>(&layout),
    );
    let sos = add_sos_constraints::<S>(&mut problem, &layout, eta, 0, t_len + p)?;
    let degenerate = add_metric_restrictions::<S>(&mut problem, &layout, options, 0)?;
    // The classical form: C_S (ψ + d) = C_S d = 0, the current ψ meeting it.
    let casimir = Equalities::new(classical::entropy_rows::<S>(), &free);
    if !casimir.is_empty() {
        problem.constrain(
            Cone::Zero(casimir.len()),
            match &centre {
                Some(shift) => shift.rows(casimir.entries(t_len), t_len, p),
                None => casimir.entries(t_len),
            },
            vec![0.0; casimir.len()],
        )?;
    }
    let mut entries = Vec::with_capacity(2 * (t_len + p));
    let mut rhs = Vec::with_capacity(2 * (t_len + p));
    // A radius near f64::MAX would make the box infinite; no coefficient
    // of a model exceeds MAX_COEFFICIENT, so that bounds the reach.
    let reach_of = |column: usize| (radius * widths[column]).min(2.0 * MAX_COEFFICIENT);
    for (t, &value) in searched_theta.iter().enumerate() {
        let reach = reach_of(t);
        entries.push((2 * t, t, 1.0));
        entries.push((2 * t + 1, t, -1.0));
        rhs.extend([value + reach, reach - value]);
    }
    for (k, &value) in psi.iter().enumerate() {
        let reach = reach_of(t_len + k);
        let row = 2 * (t_len + k);
        entries.push((row, t_len + k, 1.0));
        entries.push((row + 1, t_len + k, -1.0));
        match &centre {
            // The box |ψ + d| ≤ η on the coefficients in x gets rows of its own.
            Some(_) => rhs.extend([reach, reach]),
            None => rhs.extend([reach.min(eta - value), reach.min(eta + value)]),
        }
    }
    if let Some(centre) = &centre {
        let mut box_rows = Vec::with_capacity(2 * p);
        for (k, &value) in psi.iter().enumerate() {
            let row = rhs.len();
            box_rows.push((row, t_len + k, 1.0));
            box_rows.push((row + 1, t_len + k, -1.0));
            rhs.extend([eta - value, eta + value]);
        }
        entries.extend(centre.rows(box_rows, t_len, p));
    }
    problem.constrain(Cone::Nonnegative(rhs.len()), entries, rhs)?;
    let build_seconds = start.elapsed().as_secs_f64();
    let solution = solve_l1(&problem, &options.solver)?;

    let step = &solution.coefficients()[..t_len + p];
    // The prediction is the linearised data cost, without the penalty (for
    // the corrected step: the corrected model's).
    let predicted = step.iter().all(|v| v.is_finite()).then(|| {
        let cost = problem.regression().l1_residual_of_first(data_rows, step);
        Cost::from_sum(cost, data_rows)
    });
    let certificate = sos.certificate(&solution);
    let mut metric = theta_from_gram::<S>(&layout, &certificate.lower);
    degenerate.project_coefficients(&mut metric);
    options.support.zero_held_metric(&mut metric);
    let entropy_step = match &centre {
        Some(centre) => centre.to_original(&step[t_len..]),
        None => step[t_len..].to_vec(),
    };
    let mut entropy = all_psi.to_vec();
    for ((&k, v), d) in free.iter().zip(&psi).zip(&entropy_step) {
        entropy[k] = (v + d).clamp(-eta, eta);
    }
    casimir.project_coefficients(&mut entropy);
    let cost = Model::<S>::new(entropy.clone(), metric.clone())
        .ok()
        .and_then(|candidate| model_cost(&candidate, data).ok());
    Ok(JointStep {
        entropy,
        metric,
        certificate,
        predicted,
        report: SearchReport::new(&solution, build_seconds, cost),
    })
}

/// How far each coefficient of [θ′ | d] may move per unit of trust radius:
/// the size of coefficient needed to account alone for the residual
/// (‖t‖₁ / ‖Aₖ‖₁), or the coefficient's own size if larger. So the trust
/// region means the same in any units: data in SI units with rates of 1e6
/// need coefficient steps a million times larger than unit-scaled data.
fn trust_widths(regression: &Regression, theta: &[f64], psi: &[f64]) -> Vec<f64> {
    let residual: f64 = regression.target.iter().map(|t| t.abs()).sum();
    let current = theta.iter().chain(psi.iter().map(|_| &0.0));
    regression
        .column_l1_norms()
        .into_iter()
        .zip(current.zip(theta.iter().chain(psi)))
        .map(|(norm, (_, value))| {
            let effect = if norm > 0.0 && residual > 0.0 {
                residual / norm
            } else {
                1.0
            };
            effect.max(value.abs()).max(f64::MIN_POSITIVE)
        })
        .collect()
}

/// The proximal rows λₖ (cₖ − cₖ⁽⁰⁾) of the joint step, for columns
/// [θ′ | d] whose current values are [θ | 0]; λₖ = `STEP_PENALTY` times
/// column k's L1 norm, and columns without data get no row.
fn step_penalty(regression: &Regression, theta: &[f64]) -> Regression {
    let width = regression.width;
    let mut rows = Vec::new();
    let mut target = Vec::new();
    for (k, norm) in regression.column_l1_norms().into_iter().enumerate() {
        let weight = STEP_PENALTY * norm;
        if weight > 0.0 {
            let mut row = vec![0.0; width];
            row[k] = weight;
            rows.extend(row);
            target.push(weight * theta.get(k).copied().unwrap_or(0.0));
        }
    }
    Regression {
        width,
        rows,
        target,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::equations::sealed::Sealed;
    use crate::data::{Trajectory, WeakDataset, WeakForm};
    use crate::test_system::{reference_data, Quadratic2d};

    /// K(θ) of Quadratic2d's constant metrics, row-major.
    fn metric_matrix(theta: &[f64]) -> [f64; 4] {
        // Upper-triangle pairs (0,0), (0,1), (1,1), six monomials each.
        [theta[0], theta[6], theta[6], theta[12]]
    }

    /// ∇(d · φ)(x) for Quadratic2d's entropy monomials (q, p, q², qp, p²).
    fn entropy_gradient(d: &[f64], x: &[f64]) -> [f64; 2] {
        let (q, p) = (x[0], x[1]);
        [
            d[0] + 2.0 * d[2] * q + d[3] * p,
            d[1] + d[3] * q + 2.0 * d[4] * p,
        ]
    }

    /// The correction's premise, row by row: at a trial point (θ₁, ψ + d)
    /// the joint step's linearised residual minus the true one (computed
    /// by `model_residuals` in its own row order) is the dropped bilinear
    /// term (K(θ₁) − K(θ)) J d, summed with the equation's weights; and the
    /// shifted targets make the linearised residual there the true one.
    fn check_offset<D: IdentificationData>(data: &D) {
        let entropy: Vec<f64> = Quadratic2d::REFERENCE_ENTROPY.unwrap().to_vec();
        let mut metric = vec![0.0; 18];
        (metric[0], metric[6], metric[12]) = (0.9, 0.1, 1.2);
        let d = [0.05, -0.03, 0.02, -0.04, 0.01];
        let trial_entropy: Vec<f64> = entropy.iter().zip(d).map(|(a, b)| a + b).collect();
        let mut trial_metric = metric.clone();
        (trial_metric[0], trial_metric[6], trial_metric[12]) = (0.7, -0.05, 1.4);
        let trial = Model::<Quadratic2d>::new(trial_entropy.clone(), trial_metric.clone()).unwrap();

        let mut regression = metric_regression::<Quadratic2d>(data, &entropy)
            .unwrap()
            .with_columns_of(&entropy_regression::<Quadratic2d>(data, &metric).unwrap());
        let truth = model_residuals(&trial, data).unwrap();
        let z: Vec<f64> = trial_metric.iter().copied().chain(d).collect();
        let linearised = |regression: &Regression, r: usize| {
            let row = &regression.rows[r * regression.width..(r + 1) * regression.width];
            regression.target[r] - row.iter().zip(&z).map(|(a, b)| a * b).sum::<f64>()
        };
        let (k0, k1) = (metric_matrix(&metric), metric_matrix(&trial_metric));
        let equations = data.equations();
        assert_eq!(truth.len(), regression.target.len());
        for e in 0..equations.len() {
            let mut bilinear = [0.0; 2];
            for (j, w) in equations.terms_of(e) {
                let g = entropy_gradient(&d, equations.state(j));
                for (i, b) in bilinear.iter_mut().enumerate() {
                    *b += w
                        * ((k1[2 * i] - k0[2 * i]) * g[0] + (k1[2 * i + 1] - k0[2 * i + 1]) * g[1]);
                }
            }
            for (i, b) in bilinear.iter().enumerate() {
                let r = 2 * e + i;
                let found = linearised(&regression, r) - truth[r];
                assert!(
                    (found - b).abs() <= 1e-12 * (1.0 + b.abs()),
                    "row {r}: {found} vs {b}"
                );
            }
        }

        let offset = Offset {
            true_residuals: truth.clone(),
            metric: &trial_metric,
            entropy: &trial_entropy,
        };
        offset.apply(&mut regression, &[0, 1, 2, 3, 4], &entropy, None, None);
        for (r, t) in truth.iter().enumerate() {
            let found = linearised(&regression, r);
            assert!(
                (found - t).abs() <= 1e-12 * (1.0 + t.abs()),
                "row {r}: {found} vs {t}"
            );
        }
    }

    #[test]
    fn the_correction_is_the_dropped_bilinear_term_on_derivative_data() {
        check_offset(&reference_data(40, 5));
    }

    #[test]
    fn the_correction_is_the_dropped_bilinear_term_on_weak_form_data() {
        let trajectories: Vec<Trajectory> = (0..3)
            .map(|k| {
                let t: Vec<f64> = (0..40).map(|i| 0.05 * i as f64).collect();
                let x = t
                    .iter()
                    .flat_map(|t| [(t + k as f64).cos(), -(t + 0.5 * k as f64).sin()])
                    .collect();
                Trajectory::new(vec!["q".into(), "p".into()], t, x, None).unwrap()
            })
            .collect();
        let weak = WeakDataset::from_trajectories(&trajectories, &WeakForm::default()).unwrap();
        assert!(weak.equations().terms.is_some());
        check_offset(&weak);
    }
}
