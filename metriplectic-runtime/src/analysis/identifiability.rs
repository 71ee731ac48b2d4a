//! Which coefficient combinations the data determine.
//!
//! The vector field f(x) = (Π + K(x; θ))(∇H + J(x)ᵀψ) is bilinear in
//! (ψ, θ), so its Jacobian with respect to the coefficients, stacked over
//! the data's equations, is exact: the entropy columns are the entropy
//! search's rows (M Jᵀ), the metric columns the metric search's rows
//! (θ ↦ K(x; θ)∇E). Its numerical null space holds the directions along
//! which the fit does not change to first order — the combinations the data
//! cannot determine.
//!
//! One such direction is structural. If Π∇E = 0 on the data then
//! (cK, E/c) fits exactly as well as (K, E) for every c > 0: with
//! c = 1 + ε the change is δK = εK, δS = −εE, and the field changes by
//! −εΠ∇E = 0. When H lies in the entropy basis (its coefficients h there),
//! that is the coefficient direction (δθ, δψ) = (θ, −(ψ + h)), and the
//! report names it.
//!
//! A direction can also be hidden by the fit's own residual: when a change
//! along it as large as the whole coefficient vector moves the fit by less
//! than the residual does, noise or an unmodelled part of the data decide
//! it. Noisy data need this: the noise-fitted terms of a fit break an
//! exact degeneracy of the model by an amount of the noise's size, and the
//! singular values of those directions grow with the noise.

use nalgebra::{DMatrix, DMatrixViewMut};
use serde::{Deserialize, Serialize};

use crate::data::IdentificationData;
use crate::error::{invalid, Result};
use crate::identify::search::{
    centred_entropy_regression, centred_metric_regression, entropy_regression, entropy_shift,
    metric_regression,
};
use crate::identify::SearchOptions;
use crate::model::classical::{self, Equalities};
use crate::model::{polynomial, Model};
use crate::model::{Layout, Shift};
use crate::solve::linalg::{
    column_scales, full_rank_on_rows, least_squares, strided_rows, triangular_factor_by_blocks,
};
use crate::solve::Regression;
use crate::system::{metric_pair_index, MetriplecticSystem};

/// [`IdentifiabilityOptions::tolerance`]'s default, shared with the
/// rank warnings of an identification.
pub(crate) const DEFAULT_TOLERANCE: f64 = 1e-8;

/// The largest relative stretch of the scale direction that still counts as
/// the exact scale symmetry, whatever the options' tolerance.
const EXACT_SYMMETRY: f64 = 1e-6;

/// Options of [`identifiability`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IdentifiabilityOptions {
    /// Directions whose singular value (of the column-normalised Jacobian,
    /// relative to its largest) is at most this count as undetermined.
    /// Default 1e-8: far below what noise-free fits reach (their residuals
    /// are 1e-12 and smaller) and far above rounding. Directions up to the
    /// fit's [`misfit`](Identifiability::misfit), when that is larger,
    /// count as undetermined too ([`FlatKind::WithinMisfit`]).
    pub tolerance: f64,
    /// The parameterisation the run used: its support (coefficients held at
    /// zero are not unknowns), SOS tables (which metric coefficients the
    /// certificate leaves free) and gauge (a fixed gauge removes the
    /// direction it normalises). Default [`SearchOptions::default`].
    pub search: SearchOptions,
}

impl Default for IdentifiabilityOptions {
    fn default() -> Self {
        Self {
            tolerance: DEFAULT_TOLERANCE,
            search: SearchOptions::default(),
        }
    }
}

/// What produces a flat direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FlatKind {
    /// The structural scale symmetry (K, E) ↦ (cK, E/c), exact because
    /// Π∇E = 0 on the data; in the classical form (K, S) ↦ (cK, S/c),
    /// exact on any data since ẋ = Π∇H + K∇S there.
    ScaleSymmetry,
    /// A direction the data do not determine for no structural reason the
    /// report knows (too few or too similar samples, or a symmetry of this
    /// particular system): more varied data, a smaller basis, a gauge or a
    /// support fix it.
    Data,
    /// A direction the data would determine without their misfit: a change
    /// along it as large as the whole coefficient vector moves the fit by
    /// less than the fit's residual ([`Identifiability::misfit`]), so noise
    /// or an unmodelled part of the data decide it. Less noise, more
    /// varied data or a smaller basis fix it.
    WithinMisfit,
}

/// A combination of coefficients the data cannot determine.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FlatDirection {
    /// What produces it.
    pub kind: FlatKind,
    /// How little the fit changes along it: ‖J v‖ relative to the largest
    /// singular value, for the direction v in column-normalised units.
    pub singular_value: f64,
    /// The direction's entropy part δψ (all coefficients, largest |entry| of
    /// the whole direction 1).
    pub entropy: Vec<f64>,
    /// The direction's metric part δθ (all coefficients).
    pub metric: Vec<f64>,
    /// δS and δK as polynomials in the state names.
    pub description: String,
}

/// The identifiability report of a model on a dataset; see
/// [`identifiability`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Identifiability {
    /// Number of unknown coefficients analysed: the free entropy
    /// coefficients and the metric coefficients the certificate and support
    /// leave free, less one for a gauge.
    pub unknowns: usize,
    /// Number of independent combinations the data determine, counting
    /// those K ⪰ 0 leaves no room along as determined
    /// ([`excluded_by_positivity`](Self::excluded_by_positivity)).
    pub rank: usize,
    /// Singular values of the column-normalised Jacobian, descending,
    /// relative to the largest.
    pub singular_values: Vec<f64>,
    /// Whether Π∇E = 0 on the data, so that (cK, E/c) fits as well as
    /// (K, E) (relative size of Π∇E against (Π + K)∇E below the tolerance
    /// and below 1e-6 whatever the tolerance); for a classical system,
    /// whether (cK, S/c) does.
    pub scale_symmetry: bool,
    /// Whether the options' gauge removes the scale symmetry.
    pub gauge_fixed: bool,
    /// The directions the data cannot determine (`unknowns − rank` of them).
    pub flat_directions: Vec<FlatDirection>,
    /// Flat directions of the fit that K ⪰ 0 excludes (to second order,
    /// both signs indefinite at some data state: e.g. an off-diagonal
    /// entry in a zero row of K), counted as determined: no admissible
    /// model lies along them. They are determined less sharply than the
    /// others: a step t along one stays admissible with a change of order
    /// t² in the zero row, which moves the fit by order t², so a fit
    /// accurate to ε fixes them only to about √ε (a probe's exact fit to
    /// 1e-9 returned an off-diagonal of 1.7e-4 where the truth has 0).
    /// 0 when read from an older report.
    #[serde(default)]
    pub excluded_by_positivity: usize,
    /// The fit's residual against the effect of its coefficients,
    /// ‖r‖ / (σ_max ‖D c‖) (r the model's residual on the data, D c its
    /// column-normalised coefficients, σ_max the largest singular value):
    /// the relative singular value below which a change as large as the
    /// coefficient vector moves the fit by less than the residual
    /// ([`FlatKind::WithinMisfit`]). About 1e-15 for an exact fit; 0 when
    /// the model has no coefficients or is read from an older report.
    #[serde(default)]
    pub misfit: f64,
}

impl Identifiability {
    /// Whether the data determine every coefficient.
    pub fn is_identifiable(&self) -> bool {
        self.flat_directions.is_empty()
    }
}

impl std::fmt::Display for Identifiability {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let smallest = self.singular_values.last().copied().unwrap_or(0.0);
        if self.is_identifiable() {
            write!(
                f,
                "identifiable: the data determine all {} coefficients (smallest relative singular value {smallest:.2e})",
                self.unknowns
            )?;
            if self.scale_symmetry && self.gauge_fixed {
                write!(f, "; the scale symmetry K -> cK is fixed by the gauge")?;
            }
            if self.excluded_by_positivity > 0 {
                write!(
                    f,
                    "; K ⪰ 0 excludes {} flat direction(s) of the fit, to second order only: \
                     along them the coefficients are determined to about the square root of \
                     the fit's relative accuracy",
                    self.excluded_by_positivity
                )?;
            }
            return Ok(());
        }
        writeln!(
            f,
            "not identifiable: the data determine {} of {} coefficient combinations{}{}; undetermined:",
            self.rank,
            self.unknowns,
            if self.excluded_by_positivity > 0 {
                format!(
                    " (with K ⪰ 0, which excludes {} flat direction(s) of the fit)",
                    self.excluded_by_positivity
                )
            } else {
                String::new()
            },
            if self
                .flat_directions
                .iter()
                .any(|d| d.kind == FlatKind::WithinMisfit)
            {
                format!(" beyond the fit's misfit {:.2e}", self.misfit)
            } else {
                String::new()
            }
        )?;
        // A large basis can have dozens of flat directions, each a
        // polynomial per block: the text shows the first few, abbreviated;
        // `flat_directions` keeps them whole.
        for direction in self.flat_directions.iter().take(SHOWN_DIRECTIONS) {
            let name = match direction.kind {
                FlatKind::ScaleSymmetry => {
                    "scale symmetry K -> cK with E/c (Π∇E = 0 on the data) or S/c (classical form)"
                }
                FlatKind::Data => "not determined by these data",
                FlatKind::WithinMisfit => "within the misfit: the fit's residual hides it",
            };
            writeln!(
                f,
                "  - {name} (singular value {:.2e}): {}",
                direction.singular_value,
                abbreviate(&direction.description, SHOWN_CHARACTERS)
            )?;
        }
        if let Some(hidden) = self.flat_directions.len().checked_sub(SHOWN_DIRECTIONS) {
            if hidden > 0 {
                writeln!(f, "  - … and {hidden} more (all in `flat_directions`)")?;
            }
        }
        Ok(())
    }
}

/// Flat directions shown by the report's text.
const SHOWN_DIRECTIONS: usize = 5;

/// Characters of a direction's description shown by the report's text.
const SHOWN_CHARACTERS: usize = 400;

/// `text` cut after at most `limit` characters, at a space, with " …".
fn abbreviate(text: &str, limit: usize) -> std::borrow::Cow<'_, str> {
    if text.chars().count() <= limit {
        return text.into();
    }
    let end = text
        .char_indices()
        .nth(limit)
        .map_or(text.len(), |(i, _)| i);
    let cut = text[..end].rfind(' ').unwrap_or(end);
    format!("{} …", &text[..cut]).into()
}

/// The identifiability report of `model` on `data`: the singular values of
/// the exact Jacobian of the stacked vector field with respect to the free
/// coefficients (ψ, θ), its flat directions in readable form, and whether
/// the structural scale symmetry (K, E) ↦ (cK, E/c) holds on the data.
///
/// Columns are normalised to unit length first, so that the singular values
/// do not depend on the units of the coefficients. A direction counts as
/// undetermined when its relative singular value is at most the options'
/// tolerance or the fit's [`misfit`](Identifiability::misfit), whichever is
/// larger: on noisy data the report is of what the data determine beyond
/// their noise, not of the model's exact symmetries alone. Where E = H + S
/// is constant on the data to the tolerance (‖∇E‖ below it times
/// ‖∇H‖ + ‖∇S‖, as when S = −H fits states at rest), the metric's columns,
/// K(x; ·)∇E, are rounding: they are read at that size, and the metric is
/// reported undetermined. Errors on a dataset of the wrong dimension, a
/// support or gauge that does not fit `S`, a model that does not meet the
/// options' gauge (to 1e-6 of its value), or a failed singular value
/// decomposition.
pub fn identifiability<S: MetriplecticSystem>(
    model: &Model<S>,
    data: &impl IdentificationData,
    options: &IdentifiabilityOptions,
) -> Result<Identifiability> {
    // The report reads the gauge as fixing the model's scale: a model off
    // its gauge is not the one the gauge picks (a probe's tr K(0) = 3
    // under a gauge of 1 was reported "fixed by the gauge").
    if let Some(gauge) = options.search.gauge {
        gauge.validate()?;
        gauge.check_model::<S>("model's metric coefficients", model.metric_coefficients())?;
    }
    let jacobian = ScaledJacobian::new(model, data, options)?;
    report(&jacobian, model, data, options)
}

/// The report of [`identifiability`], or `None` when a subset of the
/// Jacobian's rows already shows that the data determine every direction
/// (the report would name no [`FlatKind::Data`] direction): what an
/// identification's joint warning asks, without factoring every row where
/// the answer is no. The same errors.
pub(crate) fn report_unless_determined<S: MetriplecticSystem>(
    model: &Model<S>,
    data: &impl IdentificationData,
    options: &IdentifiabilityOptions,
) -> Result<Option<Identifiability>> {
    let jacobian = ScaledJacobian::new(model, data, options)?;
    if jacobian.all_determined(options.tolerance) {
        return Ok(None);
    }
    report(&jacobian, model, data, options).map(Some)
}

/// [`identifiability`] from the model's scaled Jacobian on the data.
fn report<S: MetriplecticSystem>(
    jacobian: &ScaledJacobian,
    model: &Model<S>,
    data: &impl IdentificationData,
    options: &IdentifiabilityOptions,
) -> Result<Identifiability> {
    let ScaledJacobian {
        entries:
            JacobianEntries {
                entropy_rows,
                free_theta,
                free_psi,
                ..
            },
        theta_shift,
        psi_shift,
        scale,
        basis,
        ..
    } = jacobian;
    let (psi, theta) = (model.entropy_coefficients(), model.metric_coefficients());
    let in_columns = |shift: Option<&Shift>, values: &[f64]| match shift {
        Some(shift) => shift.to_centred(values),
        None => values.to_vec(),
    };
    // The coefficients as the columns read them.
    let (theta_columns, psi_columns) = (
        in_columns(theta_shift.as_ref(), theta),
        in_columns(psi_shift.as_ref(), psi),
    );
    let (rows, columns, width) = (
        jacobian.entries.rows(),
        jacobian.entries.count(),
        basis.ncols(),
    );
    let column = |row: usize, c: usize| jacobian.entries.entry(row, c);
    let gauge_fixed = options.search.gauge.is_some();
    let classical = S::CLASSICAL.is_some();
    // R of the QR factorisation of J D⁻¹ B, streamed by blocks of rows (a
    // square factor, with zero rows when there are fewer equations than
    // unknowns).
    let square = triangular_factor_by_blocks(rows, width, |first, block| {
        jacobian.fill_scaled_rows(|i| i, first, block)
    });
    let (_, singular, v) = crate::solve::linalg::svd(&square)
        .ok_or_else(|| invalid("identifiability", "the singular value decomposition failed"))?;
    let top = singular
        .first()
        .copied()
        .unwrap_or(0.0)
        .max(f64::MIN_POSITIVE);
    let relative: Vec<f64> = singular.iter().map(|s| s / top).collect();
    let misfit = misfit(
        entropy_rows,
        &psi_columns,
        scaled_size(scale, free_theta, free_psi, &theta_columns, &psi_columns),
        top,
    );
    let cut = options.tolerance.max(misfit);
    let rank = relative.iter().filter(|&&s| s > cut).count();

    // The scale direction in scaled coordinates: (θ, −(ψ + h)), E ↦ E/c,
    // if H is in the entropy basis (h its coefficients); for a classical
    // system (θ, −ψ), S ↦ S/c, since K∇H ≡ 0.
    let hamiltonian = if classical {
        Some(vec![0.0; psi.len()])
    } else {
        hamiltonian_coefficients::<S>(data)
    };
    let scale_direction = hamiltonian.and_then(|h| {
        let mut direction = vec![0.0; columns];
        for (c, &t) in free_theta.iter().enumerate() {
            direction[c] = theta_columns[t] * scale[c];
        }
        let psi_h: Vec<f64> = psi.iter().zip(&h).map(|(a, b)| a + b).collect();
        let mut outside = 0.0_f64;
        for (k, &value) in in_columns(psi_shift.as_ref(), &psi_h).iter().enumerate() {
            match free_psi.binary_search(&k) {
                Ok(c) => direction[free_theta.len() + c] = -value * scale[free_theta.len() + c],
                Err(_) => outside = outside.max(value.abs()),
            }
        }
        let size = norm(&direction);
        (size > 0.0 && outside <= 1e-9 * size).then(|| {
            direction.iter_mut().for_each(|d| *d /= size);
            direction
        })
    });
    // ‖J D⁻¹ u‖ for the unit scaled direction u, relative to the largest singular value.
    let stretch = |u: &[f64]| {
        let mut sum = 0.0;
        for row in 0..rows {
            let value: f64 = (0..columns).map(|c| column(row, c) / scale[c] * u[c]).sum();
            sum += value * value;
        }
        sum.sqrt() / top
    };
    // A loose tolerance counts more directions as undetermined; it does not
    // make Π∇E zero, which the scale symmetry needs.
    let scale_symmetry = scale_direction
        .as_ref()
        .is_some_and(|u| stretch(u) <= options.tolerance.min(EXACT_SYMMETRY));

    // The null space in scaled coordinates: B times the trailing columns of V.
    let null: Vec<Vec<f64>> = (rank..width)
        .map(|j| {
            (0..columns)
                .map(|c| (0..width).map(|i| basis[(c, i)] * v[(i, j)]).sum())
                .collect()
        })
        .collect();
    // Directions K ⪰ 0 rules out are not ambiguities of the fit.
    let excluded = excluded_by_positivity::<S>(
        model,
        data,
        &null,
        scale,
        free_theta,
        columns,
        theta_shift.as_ref(),
    )?;
    let mut remaining = null.clone();
    for u in &excluded {
        remaining = project_out(&remaining, u);
    }
    let rank = width - remaining.len();
    let mut flat = Vec::new();
    if let (true, false, Some(u)) = (scale_symmetry, gauge_fixed, &scale_direction) {
        if !remaining.is_empty() {
            flat.push((FlatKind::ScaleSymmetry, u.clone()));
            // The other null directions, orthogonal to the scale direction.
            remaining = project_out(&remaining, u);
        }
    }
    for direction in remaining {
        let kind = if stretch(&direction) <= options.tolerance {
            FlatKind::Data
        } else {
            FlatKind::WithinMisfit
        };
        flat.push((kind, direction));
    }
    let flat_directions = flat
        .into_iter()
        .map(|(kind, u)| {
            let singular_value = stretch(&u);
            readable::<S>(
                kind,
                singular_value,
                &u,
                scale,
                (free_theta, free_psi),
                (theta_shift.as_ref(), psi_shift.as_ref()),
            )
        })
        .collect();
    Ok(Identifiability {
        unknowns: width,
        rank,
        singular_values: relative,
        scale_symmetry,
        gauge_fixed,
        flat_directions,
        excluded_by_positivity: excluded.len(),
        misfit,
    })
}

/// The Jacobian's entries, unscaled: rows one per equation component,
/// columns the free θ, then the free ψ.
struct JacobianEntries {
    metric_rows: Regression,
    entropy_rows: Regression,
    free_theta: Vec<usize>,
    free_psi: Vec<usize>,
}

impl JacobianEntries {
    fn rows(&self) -> usize {
        self.metric_rows.len()
    }

    fn count(&self) -> usize {
        self.free_theta.len() + self.free_psi.len()
    }

    fn entry(&self, row: usize, c: usize) -> f64 {
        let metric = self.free_theta.len();
        if c < metric {
            self.metric_rows.rows[row * self.metric_rows.width + self.free_theta[c]]
        } else {
            self.entropy_rows.rows[row * self.entropy_rows.width + self.free_psi[c - metric]]
        }
    }
}

/// The fit's exact Jacobian J in the report's coordinates: its entries (in
/// centred coordinates where the searches fit in them), each column divided
/// by its norm (D), restricted to the directions B that keep the gauge and
/// a classical system's equalities.
struct ScaledJacobian {
    entries: JacobianEntries,
    theta_shift: Option<Shift>,
    psi_shift: Option<Shift>,
    scale: Vec<f64>,
    /// ‖J D⁻¹‖²_F, at least ‖J D⁻¹ B‖²_F (B's columns are orthonormal);
    /// not finite when an entry or a column's norm is not.
    frobenius_squared: f64,
    basis: DMatrix<f64>,
    /// Whether B is other than the identity.
    reduced: bool,
}

impl ScaledJacobian {
    /// J of `model` on `data` with `options`' parameterisation; the
    /// errors of [`identifiability`].
    fn new<S: MetriplecticSystem>(
        model: &Model<S>,
        data: &impl IdentificationData,
        options: &IdentifiabilityOptions,
    ) -> Result<Self> {
        crate::data::check_dataset::<S>(data)?;
        options.search.validate_for::<S>()?;
        if !(options.tolerance.is_finite() && options.tolerance > 0.0 && options.tolerance < 1.0) {
            return Err(invalid(
                "identifiability tolerance",
                format!("{} is not in (0, 1)", options.tolerance),
            ));
        }
        let psi = model.entropy_coefficients();
        let theta = model.metric_coefficients();
        let support = &options.search.support;
        // The report is about the coefficients the support leaves free: a
        // model it does not describe is not the fit it analyses.
        support.check_model("model", psi, theta)?;
        let free_psi = support.free_entropy::<S>();
        let free_theta = support.free_metric::<S>(options.search.sos);
        // On states or a region far from the origin the analysis reads the
        // columns in the searches' centred coordinates (`docs/method.md`
        // §2), where the monomials are not collinear to rounding, and
        // reports its directions in x. A gauge or classical rows (on x)
        // keep it in x.
        let plain = options.search.gauge.is_none() && S::CLASSICAL.is_none();
        let psi_shift = plain.then(|| entropy_shift::<S>(data, &free_psi)).flatten();
        let theta_shift = (plain && free_theta.len() == S::metric_coefficient_count())
            .then(|| {
                Layout::of::<S>(options.search.sos.tables::<S>())
                    .shift()
                    .cloned()
            })
            .flatten();
        let metric_rows = match &theta_shift {
            Some(shift) => centred_metric_regression::<S>(shift, data, psi)?,
            None => metric_regression::<S>(data, psi)?,
        };
        let entropy_rows = match &psi_shift {
            Some(shift) => centred_entropy_regression::<S>(shift, data, theta)?,
            None => entropy_regression::<S>(data, theta)?,
        };
        overflow_free(&metric_rows, data)?;
        overflow_free(&entropy_rows, data)?;
        let entries = JacobianEntries {
            metric_rows,
            entropy_rows,
            free_theta,
            free_psi,
        };
        let columns = entries.count();
        let (mut scale, frobenius_squared) =
            column_scales(entries.rows(), columns, |row, c| entries.entry(row, c));
        // Where ∇E is only the fit's cancellation of H by S, the metric's
        // columns K(x; ·)∇E are that cancellation's rounding: read at the
        // size of ∇E against its parts, they are as flat as ∇E is. (The
        // Frobenius sum only falls: it stays a bound.)
        if let Some(variation) =
            free_energy_variation::<S>(data, psi).filter(|&v| v > 0.0 && v < options.tolerance)
        {
            for d in &mut scale[..entries.free_theta.len()] {
                *d /= variation;
            }
        }
        let (free_theta, free_psi) = (&entries.free_theta, &entries.free_psi);

        // Coordinates: the free coefficients, each divided by its column
        // norm; only the directions that keep the gauge and, for a
        // classical system, the constraints (in scaled coordinates y = D c
        // a row g reads g / D).
        let mut fixed: Vec<Vec<f64>> = Vec::new();
        if let Some(gauge) = options.search.gauge {
            let (row, _) = gauge.row::<S>();
            let mut g = vec![0.0; columns];
            for (t, w) in row {
                if let Ok(c) = free_theta.binary_search(&t) {
                    g[c] = w / scale[c];
                }
            }
            fixed.push(g);
        }
        for (rows, free, offset) in [
            (classical::metric_rows::<S>(), free_theta, 0),
            (classical::entropy_rows::<S>(), free_psi, free_theta.len()),
        ] {
            for row in Equalities::new(rows, free).dense_rows() {
                let mut g = vec![0.0; columns];
                for (j, w) in row.into_iter().enumerate() {
                    g[offset + j] = w / scale[offset + j];
                }
                fixed.push(g);
            }
        }
        let basis = orthogonal_complement(&fixed, columns)?;
        let reduced = basis.ncols() != columns || !basis.is_identity(0.0);
        Ok(Self {
            entries,
            theta_shift,
            psi_shift,
            scale,
            frobenius_squared,
            basis,
            reduced,
        })
    }

    /// Writes rows `first..first + block.nrows()` of the matrix whose row i
    /// is row `row_of(i)` of J D⁻¹ B.
    fn fill_scaled_rows(
        &self,
        row_of: impl Fn(usize) -> usize,
        first: usize,
        mut block: DMatrixViewMut<'_, f64>,
    ) {
        let scaled = DMatrix::from_fn(block.nrows(), self.entries.count(), |i, c| {
            self.entries.entry(row_of(first + i), c) / self.scale[c]
        });
        if self.reduced {
            block.gemm(1.0, &scaled, &self.basis, 0.0);
        } else {
            block.copy_from(&scaled);
        }
    }

    /// Whether every singular value of J D⁻¹ B is shown to be above
    /// `tolerance` times the largest, so that no direction is left to the
    /// report's [`FlatKind::Data`], by the QR of a strided subset of the
    /// rows ([`full_rank_on_rows`]). `false` means "not shown", never
    /// "undetermined"; it is also `false` where the rows are too few for a
    /// subset to save work. Runs with the scale symmetry are never shown:
    /// its direction is exactly flat.
    fn all_determined(&self, tolerance: f64) -> bool {
        let width = self.basis.ncols();
        let Some(subset) = strided_rows(self.entries.rows(), width) else {
            return false;
        };
        full_rank_on_rows(
            subset.len(),
            width,
            self.frobenius_squared,
            tolerance,
            |first, block| self.fill_scaled_rows(|i| subset[i], first, block),
        )
    }
}

/// ‖D c‖ for the free coefficients c = (θ, ψ) scaled by their column norms D.
fn scaled_size(
    scale: &[f64],
    free_theta: &[usize],
    free_psi: &[usize],
    theta: &[f64],
    psi: &[f64],
) -> f64 {
    let values = free_theta
        .iter()
        .map(|&t| theta[t])
        .chain(free_psi.iter().map(|&k| psi[k]));
    values
        .zip(scale)
        .map(|(c, d)| (c * d).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// [`Identifiability::misfit`]: the model's residual on the data (the
/// entropy regression at its metric, so the whole field's residual) over
/// `top` times the size of its scaled coefficients; 0 without coefficients.
fn misfit(entropy_rows: &Regression, psi: &[f64], coefficients: f64, top: f64) -> f64 {
    let residual = entropy_rows.l2_residual(psi);
    let effect = top * coefficients;
    if effect > 0.0 && residual.is_finite() {
        residual / effect
    } else {
        0.0
    }
}

/// States at which `excluded_by_positivity` reads the metric's null space.
const FACE_STATES: usize = 64;

/// Relative size below which a block of δK counts as zero: a fit sits at
/// the solver's accuracy, so a zero row of K is zero only to ~1e-5.
const FACE_TOLERANCE: f64 = 1e-3;

/// The part of the flat subspace (orthonormal `null`, scaled coordinates)
/// that K ⪰ 0 excludes: along it K + tδK is indefinite for every small t
/// of either sign (beyond a sliver of the fit's accuracy), so no
/// admissible model lies that way.
///
/// At a state where K(x) has null vectors N and range vectors R, the
/// blocks of δK are D_NN = Nᵀ δK N and D_RN = Rᵀ δK N. With D_NN = 0 and
/// D_RN ≠ 0 the N-block of K + tδK has Schur complement −t² D_NR Λ⁻¹ D_RN,
/// negative for t of both signs; with D_NN ≠ 0 one sign stays admissible
/// (a one-sided ambiguity, still undetermined), and with both zero both
/// do. Sizes are relative to δK's own over the states read (up to 64 of
/// the data's, evenly spaced): the excluded part is where D_NN is below
/// `FACE_TOLERANCE` of it and D_RN is not. A null vector is an eigenvector
/// of K(x) below 1e-8 of its largest eigenvalue.
fn excluded_by_positivity<S: MetriplecticSystem>(
    model: &Model<S>,
    data: &impl IdentificationData,
    null: &[Vec<f64>],
    scale: &[f64],
    free_theta: &[usize],
    columns: usize,
    shift: Option<&Shift>,
) -> Result<Vec<Vec<f64>>> {
    if null.is_empty() || free_theta.is_empty() {
        return Ok(Vec::new());
    }
    let n = S::DIM;
    let m = S::METRIC_EXPONENTS.len();
    let flat = null.len();
    let theta = model.metric_coefficients();
    let states = data_states(data);
    let stride = states.len().div_ceil(FACE_STATES).max(1);
    // The entry (a, b) each free coefficient belongs to, looked up once.
    let entries: Vec<Option<(usize, usize)>> =
        free_theta.iter().map(|&t| pair_entry(n, t / m)).collect();
    let mut metric = vec![0.0; n * n];
    let mut features = vec![0.0; m];
    // Σ r rᵀ over the forms r of δK's entries, of D_NN and of D_RN, each
    // restricted to the flat subspace (r_j = form · null_j).
    let mut size = DMatrix::<f64>::zeros(flat, flat);
    let mut null_block = DMatrix::<f64>::zeros(flat, flat);
    let mut range_block = DMatrix::<f64>::zeros(flat, flat);
    let mut any_null = false;
    for x in states.iter().step_by(stride) {
        S::metric_value(x, theta, &mut metric);
        let matrix = DMatrix::from_row_slice(n, n, &metric);
        let Some((values, vectors)) = crate::solve::linalg::symmetric_eigen(&matrix) else {
            continue;
        };
        let largest = values.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let is_null: Vec<bool> = values.iter().map(|&v| v <= 1e-8 * largest).collect();
        // The θ columns read the metric's monomials where the search does.
        match shift {
            Some(shift) => {
                let mut y = vec![0.0; n];
                shift.centred_state(x, &mut y);
                S::metric_features(&y, &mut features);
            }
            None => S::metric_features(x, &mut features),
        }
        // The form δθ ↦ vᵀ δK(x) w on the scaled columns, restricted.
        let restricted = |v: &[f64], w: &[f64]| -> nalgebra::DVector<f64> {
            let mut row = vec![0.0; columns];
            for (c, (&t, entry)) in free_theta.iter().zip(&entries).enumerate() {
                let Some((a, b)) = *entry else {
                    continue;
                };
                let weight = if a == b {
                    v[a] * w[a]
                } else {
                    v[a] * w[b] + v[b] * w[a]
                };
                row[c] = weight * features[t % m] / scale[c];
            }
            nalgebra::DVector::from_fn(flat, |j, _| {
                row.iter().zip(&null[j]).map(|(a, b)| a * b).sum()
            })
        };
        let column = |i: usize| -> Vec<f64> { vectors.column(i).iter().copied().collect() };
        for a in 0..n {
            for b in a..n {
                let r = restricted(&column(a), &column(b));
                size += &r * r.transpose();
                match (is_null[a], is_null[b]) {
                    (true, true) => {
                        any_null = true;
                        null_block += &r * r.transpose();
                    }
                    (true, false) | (false, true) => range_block += &r * r.transpose(),
                    (false, false) => {}
                }
            }
        }
    }
    if !any_null {
        return Ok(Vec::new());
    }
    // Whiten by δK's size: w = Λ^½ Vᵀ z, so that |w| is the size of the
    // change of K along u = Σ zⱼ nullⱼ. Directions that leave K alone
    // (pure entropy changes) are never excluded.
    let Some((values, vectors)) = crate::solve::linalg::symmetric_eigen(&size) else {
        return Ok(Vec::new());
    };
    let top = values.iter().fold(0.0_f64, |a, v| a.max(*v));
    let kept: Vec<usize> = (0..flat).filter(|&i| values[i] > 1e-20 * top).collect();
    if kept.is_empty() {
        return Ok(Vec::new());
    }
    let unwhiten = DMatrix::from_fn(flat, kept.len(), |r, c| {
        vectors[(r, kept[c])] / values[kept[c]].sqrt()
    });
    let relative = |block: &DMatrix<f64>, basis: &DMatrix<f64>| {
        let whitened = basis.transpose() * block * basis;
        crate::solve::linalg::symmetric_eigen(&whitened)
    };
    let tolerance = FACE_TOLERANCE * FACE_TOLERANCE;
    // Where D_NN is negligible against δK…
    let Some((null_values, null_vectors)) = relative(&null_block, &unwhiten) else {
        return Ok(Vec::new());
    };
    let small: Vec<usize> = (0..kept.len())
        .filter(|&i| null_values[i] <= tolerance)
        .collect();
    if small.is_empty() {
        return Ok(Vec::new());
    }
    let within =
        &unwhiten * DMatrix::from_fn(kept.len(), small.len(), |r, c| null_vectors[(r, small[c])]);
    // …and D_RN is not.
    let Some((range_values, range_vectors)) = relative(&range_block, &within) else {
        return Ok(Vec::new());
    };
    let excluded: Vec<Vec<f64>> = (0..small.len())
        .filter(|&i| range_values[i] > tolerance)
        .map(|i| {
            let z = &within * range_vectors.column(i);
            let mut u: Vec<f64> = (0..columns)
                .map(|c| (0..flat).map(|j| null[j][c] * z[j]).sum())
                .collect();
            let length = norm(&u);
            u.iter_mut().for_each(|v| *v /= length);
            u
        })
        .collect();
    // Orthonormal, as the caller projects them out one by one.
    Ok(gram_schmidt(excluded.iter().map(Vec::as_slice), None, 1e-8))
}

/// The entry (a, b), a ≤ b, of upper-triangle pair index `pair`.
fn pair_entry(n: usize, pair: usize) -> Option<(usize, usize)> {
    (0..n)
        .flat_map(|a| (a..n).map(move |b| (a, b)))
        .find(|&(a, b)| metric_pair_index(n, a, b) == pair)
}

/// The direction in coefficient units (c = D⁻¹ y), scaled to largest
/// |entry| 1 with the sign that makes its largest entry positive, and its
/// description.
fn readable<S: MetriplecticSystem>(
    kind: FlatKind,
    singular_value: f64,
    scaled: &[f64],
    scale: &[f64],
    (free_theta, free_psi): (&[usize], &[usize]),
    (theta_shift, psi_shift): (Option<&Shift>, Option<&Shift>),
) -> FlatDirection {
    let mut entropy = vec![0.0; S::entropy_coefficient_count()];
    let mut metric = vec![0.0; S::metric_coefficient_count()];
    for (c, (&y, &d)) in scaled.iter().zip(scale).enumerate() {
        match c.checked_sub(free_theta.len()) {
            None => metric[free_theta[c]] = y / d,
            Some(k) => entropy[free_psi[k]] = y / d,
        }
    }
    // Reported on the coefficients in x.
    if let Some(shift) = theta_shift {
        metric = shift.to_original(&metric);
    }
    if let Some(shift) = psi_shift {
        entropy = shift.to_original(&entropy);
    }
    let largest =
        entropy
            .iter()
            .chain(&metric)
            .fold(0.0_f64, |m, v| if v.abs() > m.abs() { *v } else { m });
    if largest != 0.0 {
        entropy.iter_mut().chain(metric.iter_mut()).for_each(|v| {
            *v /= largest;
            // Entries below the SVD's accuracy are noise, not part of the direction.
            if v.abs() < 1e-9 {
                *v = 0.0;
            }
        });
    }
    let names = S::STATE_NAMES;
    let mut description = format!(
        "δS ∝ {}",
        polynomial(names, S::ENTROPY_EXPONENTS, &entropy, 4)
    );
    let (n, basis) = (S::DIM, S::METRIC_EXPONENTS.len());
    for j in 0..n {
        for k in j..n {
            let pair = metric_pair_index(n, j, k);
            let part = &metric[pair * basis..(pair + 1) * basis];
            if part.iter().any(|v| *v != 0.0) {
                description.push_str(&format!(
                    ", δK[{},{}] ∝ {}",
                    names[j],
                    names[k],
                    polynomial(names, S::METRIC_EXPONENTS, part, 4)
                ));
            }
        }
    }
    FlatDirection {
        kind,
        singular_value,
        entropy,
        metric,
        description,
    }
}

/// The coefficients h of H in the entropy basis (∇H = J(x)ᵀh on the data's
/// states), or `None` if H is not in its span (relative residual above 1e-9).
pub(crate) fn hamiltonian_coefficients<S: MetriplecticSystem>(
    data: &impl IdentificationData,
) -> Option<Vec<f64>> {
    let states = data_states(data);
    let (n, p) = (S::DIM, S::entropy_coefficient_count());
    // Enough states to pin p coefficients, spread over the data.
    let wanted = states.len().min((2 * p).max(500));
    let stride = (states.len() / wanted.max(1)).max(1);
    let chosen: Vec<&[f64]> = states.iter().step_by(stride).copied().collect();
    let mut a = DMatrix::<f64>::zeros(chosen.len() * n, p);
    let mut b = nalgebra::DVector::<f64>::zeros(chosen.len() * n);
    let mut jacobian = vec![0.0; p * n];
    let mut grad = vec![0.0; n];
    for (i, x) in chosen.iter().enumerate() {
        S::entropy_jacobian(x, &mut jacobian);
        S::hamiltonian_gradient(x, &mut grad);
        for j in 0..n {
            for k in 0..p {
                a[(i * n + j, k)] = jacobian[k * n + j];
            }
            b[i * n + j] = grad[j];
        }
    }
    if a.nrows() < p {
        return None;
    }
    let h = least_squares(&a, &b, 1e-14)?;
    let residual = (&a * &h - &b).norm();
    (residual <= 1e-9 * b.norm().max(f64::MIN_POSITIVE)).then(|| h.iter().copied().collect())
}

/// The distinct sampled states of the data.
pub(crate) fn data_states(data: &impl IdentificationData) -> Vec<&[f64]> {
    let equations = data.equations();
    equations.states.chunks_exact(equations.dim).collect()
}

/// How much E = H + S varies on the data against its parts: the root mean
/// square of ∇E over the data's states divided by that of ∇H plus that of
/// ∇S; `None` when both parts vanish there. Near zero when S cancels H on
/// the data (states at rest fitted by S = −H): ∇E is then the fit's
/// rounding, and K∇E, all the data say of K, says nothing.
pub(crate) fn free_energy_variation<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    psi: &[f64],
) -> Option<f64> {
    let n = S::DIM;
    let (mut grad_h, mut grad_s) = (vec![0.0; n], vec![0.0; n]);
    let (mut energy, mut hamiltonian, mut entropy) = (0.0, 0.0, 0.0);
    for x in data_states(data) {
        S::hamiltonian_gradient(x, &mut grad_h);
        S::entropy_gradient(x, psi, &mut grad_s);
        for (h, s) in grad_h.iter().zip(&grad_s) {
            energy += (h + s) * (h + s);
            hamiltonian += h * h;
            entropy += s * s;
        }
    }
    let parts = hamiltonian.sqrt() + entropy.sqrt();
    (parts > 0.0 && parts.is_finite()).then(|| energy.sqrt() / parts)
}

/// Errors unless every entry of `regression` has a finite square (column
/// norms and the factorisation square them), naming the first equation
/// that does not (and its state, for pointwise data): states so large that
/// the basis's monomials reach 1e154 made the factorisation fail with "the
/// singular value decomposition failed".
fn overflow_free(regression: &Regression, data: &impl IdentificationData) -> Result<()> {
    let width = regression.width.max(1);
    let square_finite = |v: &f64| (v * v).is_finite();
    let Some(row) = regression
        .rows
        .chunks(width)
        .zip(&regression.target)
        .position(|(row, target)| !(square_finite(target) && row.iter().all(square_finite)))
    else {
        return Ok(());
    };
    let equations = data.equations();
    let equation = row / equations.dim.max(1);
    let state = match equations.terms {
        None => format!(
            " (x = {:?})",
            &equations.states[equation * equations.dim..(equation + 1) * equations.dim]
        ),
        Some(_) => String::new(),
    };
    Err(invalid(
        "identifiability",
        format!(
            "equation {equation}{state}: the fit's Jacobian there has entries whose squares \
             overflow f64: the states are too large for the basis; rescale the states"
        ),
    ))
}

/// An orthonormal basis (columns) of the vectors of length `k` orthogonal
/// to every row of `rows`: the right singular vectors of the stacked unit
/// rows beyond their rank (the identity without rows). The SVD is of the
/// rows themselves, not of Σ g gᵀ: that k × k matrix squares the condition
/// number, and with few rows among many unknowns (most of it zero) its
/// decomposition took seconds where the rows' takes milliseconds.
fn orthogonal_complement(rows: &[Vec<f64>], k: usize) -> Result<DMatrix<f64>> {
    let units: Vec<Vec<f64>> = rows
        .iter()
        .filter_map(|g| {
            let size = norm(g);
            (size > 0.0).then(|| g.iter().map(|v| v / size).collect())
        })
        .collect();
    if units.is_empty() {
        return Ok(DMatrix::identity(k, k));
    }
    let stacked = DMatrix::from_fn(units.len(), k, |i, j| units[i][j]);
    let (_, singular, v) = crate::solve::linalg::svd(&stacked)
        .ok_or_else(|| invalid("identifiability", "the singular value decomposition failed"))?;
    let top = singular.first().copied().unwrap_or(0.0);
    // σ ≤ 1e-5 σ_max counts as zero (1e-10 on the eigenvalues of Σ g gᵀ).
    let rank = singular.iter().filter(|&&s| s > 1e-5 * top).count();
    Ok(DMatrix::from_fn(k, k - rank, |a, b| v[(a, rank + b)]))
}

/// The vectors with their component along the unit vector `u` removed,
/// re-orthonormalised; one fewer than given when `u` lay in their span.
fn project_out(vectors: &[Vec<f64>], u: &[f64]) -> Vec<Vec<f64>> {
    let mut kept = gram_schmidt(vectors.iter().map(Vec::as_slice), Some(u), 1e-6);
    kept.truncate(vectors.len().saturating_sub(1));
    kept
}

/// Gram–Schmidt: each vector made orthogonal to the unit vector `against`
/// (if any) and to those kept before it, and kept, normalised, unless it is
/// left shorter than `tolerance`.
fn gram_schmidt<'a>(
    vectors: impl IntoIterator<Item = &'a [f64]>,
    against: Option<&[f64]>,
    tolerance: f64,
) -> Vec<Vec<f64>> {
    let mut kept: Vec<Vec<f64>> = Vec::new();
    for v in vectors {
        let mut w = v.to_vec();
        for basis in against.into_iter().chain(kept.iter().map(Vec::as_slice)) {
            let dot: f64 = w.iter().zip(basis).map(|(a, b)| a * b).sum();
            w.iter_mut().zip(basis).for_each(|(a, b)| *a -= dot * b);
        }
        let size = norm(&w);
        if size > tolerance {
            w.iter_mut().for_each(|a| *a /= size);
            kept.push(w);
        }
    }
    kept
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model off the options' gauge is refused: a probe's tr K(0) = 3
    /// under a gauge of 1 was reported with the scale "fixed by the gauge".
    #[test]
    fn a_model_off_its_gauge_is_refused() {
        use crate::test_system::Quadratic2d;
        use crate::{Dataset, Gauge, Model, SearchOptions};
        // The identity metric: pairs (0,0) and (1,1) at offsets 0 and 12.
        let mut theta = vec![0.0; Quadratic2d::metric_coefficient_count()];
        theta[0] = 1.0;
        theta[12] = 1.0;
        let entropy = vec![0.0; Quadratic2d::entropy_coefficient_count()];
        let model = Model::<Quadratic2d>::new(entropy, theta).unwrap();
        let states: Vec<f64> = (0..40).map(|k| (0.37 * k as f64).sin()).collect();
        let mut derivatives = vec![0.0; states.len()];
        for (x, dx) in states.chunks_exact(2).zip(derivatives.chunks_exact_mut(2)) {
            model.vector_field(x, dx).unwrap();
        }
        let data = Dataset::from_flat(2, states, derivatives).unwrap();
        let options = |trace: f64| IdentifiabilityOptions {
            search: SearchOptions {
                gauge: Some(Gauge::MetricTrace(trace)),
                ..SearchOptions::default()
            },
            ..IdentifiabilityOptions::default()
        };
        let err = identifiability(&model, &data, &options(1.0))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("the gauge fixes tr K(0) = 1, they give 2"),
            "{err}"
        );
        identifiability(&model, &data, &options(2.0)).unwrap();
    }

    #[test]
    fn the_text_of_many_long_directions_is_abbreviated_and_counts_the_rest() {
        let long = (0..200)
            .map(|k| format!("+ {k}.5 x^{k}"))
            .collect::<Vec<_>>()
            .join(" ");
        let direction = FlatDirection {
            kind: FlatKind::Data,
            singular_value: 1e-14,
            entropy: vec![1.0],
            metric: vec![],
            description: format!("δS ∝ {long}"),
        };
        let report = Identifiability {
            unknowns: 40,
            rank: 32,
            singular_values: vec![1.0; 40],
            scale_symmetry: false,
            gauge_fixed: false,
            flat_directions: vec![direction; 8],
            excluded_by_positivity: 0,
            misfit: 0.0,
        };
        let text = report.to_string();
        assert_eq!(
            text.matches("not determined by these data").count(),
            5,
            "{text}"
        );
        assert!(
            text.contains("… and 3 more (all in `flat_directions`)"),
            "{text}"
        );
        // Each shown line stops at a space within its limit.
        for line in text.lines().filter(|l| l.contains("δS")) {
            assert!(line.ends_with(" …") && line.chars().count() < 500, "{line}");
        }
        assert_eq!(abbreviate("short", 400), "short");
        assert_eq!(abbreviate("ab cd ef", 5), "ab …");
    }

    #[test]
    fn the_complement_is_orthonormal_and_orthogonal_to_the_vector() {
        for g in [vec![1.0, 1.0, 1.0], vec![0.0, -2.0, 0.5, 3.0], vec![5.0]] {
            let basis = orthogonal_complement(std::slice::from_ref(&g), g.len()).unwrap();
            assert_eq!(basis.ncols(), g.len() - 1);
            let gram = basis.transpose() * &basis;
            assert!((gram - DMatrix::identity(g.len() - 1, g.len() - 1)).norm() < 1e-14);
            let along = nalgebra::DVector::from_vec(g.clone()).transpose() * &basis;
            assert!(along.norm() < 1e-14 * norm(&g));
        }
    }

    #[test]
    fn the_complement_of_dependent_rows_keeps_their_rank() {
        // Two equal rows and their sum span one direction of R³.
        let rows = vec![
            vec![1.0, 2.0, 0.0],
            vec![1.0, 2.0, 0.0],
            vec![2.0, 4.0, 0.0],
        ];
        let basis = orthogonal_complement(&rows, 3).unwrap();
        assert_eq!(basis.ncols(), 2);
        let gram = basis.transpose() * &basis;
        assert!((gram - DMatrix::identity(2, 2)).norm() < 1e-14);
        let along = nalgebra::DVector::from_vec(rows[0].clone()).transpose() * &basis;
        assert!(along.norm() < 1e-14);
    }

    /// Few rows among many unknowns, most columns zero (as the fixed
    /// constraints of a large system are): the complement has every other
    /// direction, and the free unknowns' unit vectors lie in it.
    #[test]
    fn the_complement_of_a_few_rows_among_many_unknowns() {
        let k = 900;
        let rows: Vec<Vec<f64>> = (0..3)
            .map(|i| {
                (0..k)
                    .map(|j| if j < 5 { (i + j) as f64 } else { 0.0 })
                    .collect()
            })
            .collect();
        let basis = orthogonal_complement(&rows, k).unwrap();
        // The three rows span two directions ((i + j) is affine in i).
        assert_eq!(basis.ncols(), k - 2);
        let gram = basis.transpose() * &basis;
        assert!((gram - DMatrix::identity(k - 2, k - 2)).amax() < 1e-13);
        for row in &rows {
            let along = nalgebra::DVector::from_vec(row.clone()).transpose() * &basis;
            assert!(along.amax() < 1e-13);
        }
        // e₁₀ (an unknown no row reads) is kept whole by the projection.
        let e = basis.row(10);
        assert!((e.norm() - 1.0).abs() < 1e-13);
    }

    #[test]
    fn projecting_out_a_vector_in_the_span_drops_one_direction() {
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let vectors = vec![vec![1.0, 0.0, 0.0], vec![0.0, 1.0, 0.0]];
        let kept = project_out(&vectors, &[s, s, 0.0]);
        assert_eq!(kept.len(), 1);
        assert!((kept[0][0] + kept[0][1]).abs() < 1e-15 && kept[0][2] == 0.0);
    }
}
