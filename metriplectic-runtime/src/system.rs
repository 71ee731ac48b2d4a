//! The compile-time description of a system: what `metriplectic!` generates.

/// The sum-of-squares (SOS) certificate tables of the metric basis.
///
/// With m(x) the SOS basis monomials and Z(x) = I_n ⊗ m(x), a metric written as
/// K(x) = Z(x)ᵀ Q Z(x) with a Gram matrix Q ⪰ 0 is positive semidefinite for
/// every x. Matching the coefficient of yⱼ yₖ x^α on both sides gives
///
/// θⱼₖ,α = Σ_{(β, γ) ∈ `matching[α]`} Q[(j, β), (k, γ)],
///
/// where the Gram index of (j, β) is `j * exponents.len() + β`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SosTables {
    /// The SOS basis monomials m(x), graded lexicographic.
    pub exponents: &'static [&'static [u32]],
    /// For each metric monomial α (indexing
    /// [`MetriplecticSystem::METRIC_EXPONENTS`]), the pairs (β, γ) of indices
    /// into [`exponents`](Self::exponents) with β + γ = α. Pairs are ordered;
    /// both (β, γ) and (γ, β) appear when β ≠ γ. An empty list means the
    /// coefficient is forced to zero by the certificate.
    pub matching: &'static [&'static [(u16, u16)]],
}

/// One non-zero entry of the entropy Jacobian: `(k, j, a, i)` says
/// ∂φₖ/∂xⱼ = a · μᵢ(x), where φₖ is entropy monomial k, a = α_kj its exponent
/// of variable j, and μᵢ is monomial i of the graded-lex sequence (the
/// monomial x^(α_k − e_j), of degree below the entropy degree).
pub type JacobianTerm = (u32, u32, u32, u32);

/// A polynomial as (coefficient, exponent vector) terms.
pub type PolynomialTerms = &'static [(f64, &'static [u32])];

/// A sparse linear form Σ c·vᵢ over a coefficient vector, as (index i, c).
pub type LinearForm = &'static [(u32, f64)];

/// A region R = {x : gₖ(x) ≥ 0} of the state space on which a metric
/// certificate holds (`region` in `metriplectic!`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Region {
    /// ‖x − center‖ ≤ radius: the one constraint g = radius² − ‖x − center‖².
    Ball {
        /// Centre.
        center: &'static [f64],
        /// Radius (> 0).
        radius: f64,
    },
    /// lowerⱼ ≤ xⱼ ≤ upperⱼ: the constraints gⱼ = (upperⱼ − xⱼ)(xⱼ − lowerⱼ).
    Box {
        /// Lower bounds, one per state variable.
        lower: &'static [f64],
        /// Upper bounds (each above its lower bound).
        upper: &'static [f64],
    },
}

impl Region {
    /// Whether `x` (of the region's dimension) lies in the region.
    pub fn contains(&self, x: &[f64]) -> bool {
        match *self {
            Self::Ball { center, radius } => {
                let distance: f64 = x.iter().zip(center).map(|(a, c)| (a - c) * (a - c)).sum();
                x.len() == center.len() && distance <= radius * radius
            }
            Self::Box { lower, upper } => {
                x.len() == lower.len()
                    && x.iter()
                        .zip(lower.iter().zip(upper))
                        .all(|(v, (l, u))| (*l..=*u).contains(v))
            }
        }
    }

    /// The smallest box (lower corner, upper corner) holding the region.
    pub fn bounding_box(&self) -> (Vec<f64>, Vec<f64>) {
        match *self {
            Self::Ball { center, radius } => (
                center.iter().map(|c| c - radius).collect(),
                center.iter().map(|c| c + radius).collect(),
            ),
            Self::Box { lower, upper } => (lower.to_vec(), upper.to_vec()),
        }
    }
}

/// Which bounds of 0 ⪯ K(x) ⪯ ηI a region certificate proves where.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum CertificateMode {
    /// K(x) ⪰ 0 for every x (so the free energy never decreases anywhere)
    /// and K(x) ⪯ ηI on the region (the default).
    GlobalLowerBound,
    /// Both bounds only on the region: dE/dt ≥ 0 is certified only there.
    OnRegion,
}

/// One sum-of-squares block of a certificate: g(x)·Z(x)ᵀ Q Z(x) with
/// Z(x) = I_n ⊗ m(x), Q ⪰ 0, and g a region constraint (or 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GramBlock {
    /// The multiplier g(x); empty for the plain block (g = 1).
    pub multiplier: PolynomialTerms,
    /// The block's basis monomials m(x).
    pub exponents: &'static [&'static [u32]],
    /// For each target monomial α (indexing
    /// [`RegionCertificate::targets`]), the triples (β, γ, c): the
    /// coefficient of x^α in g(x)·x^β·x^γ is c, so that
    /// [g Zᵀ Q Z]ⱼₖ,α = Σ c·Q[(j, β), (k, γ)]. Pairs are ordered.
    pub matching: &'static [&'static [(u16, u16, f64)]],
}

/// The sum-of-squares certificate of a metric on a region (`region` in
/// `metriplectic!`), following the matrix S-procedure:
///
/// ```text
/// K(x)       = Σ_lower  gᵦ(x) Z(x)ᵀ Qᵦ Z(x),   Qᵦ ⪰ 0,
/// ηI − K(x)  = Σ_upper  gᵦ(x) Z(x)ᵀ Qᵦ Z(x),   Qᵦ ⪰ 0,
/// ```
///
/// matched coefficient by coefficient on [`targets`](Self::targets): θ on
/// the metric monomials (a prefix of the targets), zero above them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegionCertificate {
    /// Where the certificate holds.
    pub region: Region,
    /// Which bounds hold where.
    pub mode: CertificateMode,
    /// How far the multiplier degrees are raised (`relaxation order`, 0 by default).
    pub relaxation_order: u32,
    /// All monomials the blocks can produce, graded lexicographic; the
    /// metric basis is their prefix.
    pub targets: &'static [&'static [u32]],
    /// Blocks whose sum is K(x).
    pub lower: &'static [GramBlock],
    /// Blocks whose sum is ηI − K(x).
    pub upper: &'static [GramBlock],
}

/// The classical (GENERIC) form of a system (`classical;` in
/// `metriplectic!`): the entropy is a Casimir of Π (Π∇S ≡ 0) and the metric
/// is degenerate along ∇H (K∇H ≡ 0), so H is conserved and S produced.
/// Both conditions are polynomial identities, linear in the coefficients;
/// the macro derives them exactly over the rationals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Classical {
    /// The rows of C_S ψ = 0 (each a linear form in ψ) that make S a Casimir.
    pub entropy_constraints: &'static [LinearForm],
    /// A basis of the polynomial Casimirs in the entropy basis: every
    /// admissible ψ is a combination of these vectors.
    pub casimir_basis: &'static [LinearForm],
    /// The rows of C_K θ = 0 (each a linear form in θ) that make K∇H ≡ 0.
    pub metric_constraints: &'static [LinearForm],
}

/// A generalized metriplectic system ẋ = (Π(x) + K(x)) (∇H(x) + ∇S(x)) with
/// known Π and H and polynomial bases for the unknown S and K.
///
/// Implemented by the `metriplectic!` macro (see its documentation for the
/// DSL). A [`MetriplecticSystem`] is a type (usually a unit struct) that carries the
/// known parts of a generalized metriplectic system — the state, the Poisson
/// tensor Π(x), the Hamiltonian H(x) — together with the polynomial bases in
/// which the unknown entropy S(x) and metric K(x) are sought. Users do not
/// implement it by hand; the `metriplectic!` macro does, after checking the
/// system symbolically.
///
/// The macro generates only what depends on the system: the tables, H, ∇H,
/// Π, the monomials and the entropy gradient as straight-line code. Every
/// loop that is the same for all systems (features, Jacobian, metric value,
/// the per-sample rows of the searches) is a provided method of the trait.
///
/// # Conventions
///
/// * States are slices of length [`DIM`](MetriplecticSystem::DIM) in the order
///   of [`STATE_NAMES`](MetriplecticSystem::STATE_NAMES).
/// * Matrices are dense, row-major slices: entry (j, k) of an n×m matrix is at
///   `j * m + k`.
/// * Monomials are exponent vectors, one exponent per state variable, listed in
///   **graded lexicographic** order: by total degree, then, within a degree,
///   larger exponents of earlier variables first. For x = (q, p) at degree ≤ 2:
///   `1, q, p, q², q p, p²`. Every basis is a prefix of this one sequence.
/// * Entropy: S(x) = Σₖ ψₖ φₖ(x) over [`ENTROPY_EXPONENTS`](MetriplecticSystem::ENTROPY_EXPONENTS),
///   all monomials of degree 1..=r. The constant monomial is left out: its
///   gradient is zero, so its coefficient cannot be identified from (x, ẋ).
/// * Metric: K(x)ⱼₖ = Σₐ θⱼₖ,ₐ φₐ(x) over [`METRIC_EXPONENTS`](MetriplecticSystem::METRIC_EXPONENTS),
///   all monomials of degree 0..=s, with θⱼₖ = θₖⱼ. The coefficient vector θ
///   stores the upper-triangle pairs (j ≤ k) in row-major order, each pair a
///   contiguous block of `METRIC_EXPONENTS.len()` coefficients.
///
/// # Panics
///
/// The evaluation functions take slices whose lengths are fixed by the system
/// (documented on each function) and panic if a length is wrong, exactly like
/// [`slice::copy_from_slice`]. Everything in this crate that calls them checks
/// the lengths of user data first and reports a typed error instead.
pub trait MetriplecticSystem: Copy + Default + Send + Sync + std::fmt::Debug + 'static {
    /// The system's name, as declared in the macro.
    const NAME: &'static str;
    /// State dimension n.
    const DIM: usize;
    /// Names of the state variables, in state order.
    const STATE_NAMES: &'static [&'static str];
    /// Entropy degree r: the entropy basis holds the monomials of degree 1..=r.
    const ENTROPY_DEGREE: u32;
    /// Metric degree s (even): each metric entry spans the monomials of degree 0..=s.
    const METRIC_DEGREE: u32;
    /// Entropy basis φ_r, graded lexicographic, without the constant monomial.
    const ENTROPY_EXPONENTS: &'static [&'static [u32]];
    /// Metric basis φ_s, graded lexicographic, starting with the constant monomial.
    const METRIC_EXPONENTS: &'static [&'static [u32]];
    /// The non-zero entries of the entropy Jacobian, row by row.
    const ENTROPY_JACOBIAN: &'static [JacobianTerm];
    /// SOS tables over the full half-degree basis (all monomials of degree
    /// ≤ s/2). Kept for region-limited certificates, where nothing collapses.
    const SOS_FULL: SosTables;
    /// SOS tables after facial reduction, used by the metric search.
    ///
    /// For the two-sided global constraint 0 ⪯ K(x) ⪯ ηI the Gram matrices of
    /// K and of ηI − K sum to a constant, which forces every row of a
    /// non-constant monomial to zero in both: the basis reduces to the
    /// constant monomial and the certificate to 0 ⪯ K₀ ⪯ ηI.
    const SOS_REDUCED: SosTables;
    /// Entropy coefficients ψ of the declared reference model, if any
    /// (its constant term, which has no effect on the dynamics, is dropped).
    const REFERENCE_ENTROPY: Option<&'static [f64]>;
    /// Metric coefficients θ of the declared reference model, if any.
    const REFERENCE_METRIC: Option<&'static [f64]>;
    /// The metric certificate on a declared region; `None` (the default)
    /// for the global certificate with the facially reduced tables
    /// ([`SOS_REDUCED`](Self::SOS_REDUCED)), which force K constant.
    const REGION_CERTIFICATE: Option<RegionCertificate> = None;
    /// The classical (GENERIC) constraints, if the system is declared
    /// classical; `None` (the default) for the generalized form.
    const CLASSICAL: Option<Classical> = None;
    /// The largest |coefficient| of the Hamiltonian's non-constant terms in
    /// the monomial basis: the scale the default coefficient bound follows
    /// ([`SearchOptions::eta`](crate::SearchOptions::eta)). The macro
    /// computes it exactly; default 0 (unknown, the bound's floor applies).
    const HAMILTONIAN_SCALE: f64 = 0.0;
    /// The largest |coefficient| of the Poisson tensor Π(x)'s entries in
    /// the monomial basis: the scale of the conservative part of the flow,
    /// which the default bound K ⪯ ηI follows too, since a metric in the
    /// same units is of its order (Π = 1/m or 1/I carries a system's mass
    /// or inertia). The macro computes it exactly; default 0 (unknown).
    const POISSON_SCALE: f64 = 0.0;

    /// H(x). `x.len() == DIM`.
    fn hamiltonian(x: &[f64]) -> f64;
    /// ∇H(x) into `grad` (`DIM`).
    fn hamiltonian_gradient(x: &[f64], grad: &mut [f64]);
    /// Π(x) into `poisson` (`DIM × DIM`, row-major).
    fn poisson(x: &[f64], poisson: &mut [f64]);
    /// The first `out.len()` monomials of the graded-lex sequence at `x`
    /// (1, x₁, …, xₙ, x₁², …), at most [`monomial_count`](Self::monomial_count).
    fn monomials(x: &[f64], out: &mut [f64]);

    /// Number of monomials of degree ≤ max(r, s): the longest prefix
    /// [`monomials`](Self::monomials) computes.
    fn monomial_count() -> usize {
        (Self::ENTROPY_EXPONENTS.len() + 1).max(Self::METRIC_EXPONENTS.len())
    }

    /// Number of entropy coefficients p = `ENTROPY_EXPONENTS.len()`.
    fn entropy_coefficient_count() -> usize {
        Self::ENTROPY_EXPONENTS.len()
    }

    /// Number of metric coefficients: n(n+1)/2 upper-triangle pairs times the
    /// metric basis size.
    fn metric_coefficient_count() -> usize {
        Self::DIM * (Self::DIM + 1) / 2 * Self::METRIC_EXPONENTS.len()
    }

    /// Number of monomials of degree below r: all that the entropy's
    /// derivatives read (the monomials [`ENTROPY_JACOBIAN`](Self::ENTROPY_JACOBIAN) indexes).
    fn derivative_monomial_count() -> usize {
        // All monomials of degree ≤ r − 1 in n variables: C(n + r − 1, n),
        // computed in closed form so that it folds to a constant.
        let (n, r) = (Self::DIM, Self::ENTROPY_DEGREE as usize);
        (1..=n).fold(1, |count, i| count * (r - 1 + i) / i)
    }

    /// Entropy features φ_r(x) into `features` (`ENTROPY_EXPONENTS.len()`).
    fn entropy_features(x: &[f64], features: &mut [f64]) {
        let p = Self::entropy_coefficient_count();
        assert_eq!(features.len(), p, "{}: entropy features", Self::NAME);
        with_scratch(p + 1, |all| {
            Self::monomials(x, all);
            features.copy_from_slice(&all[1..]);
        });
    }

    /// Jacobian of the entropy features into `jacobian`
    /// (`ENTROPY_EXPONENTS.len() × DIM`, row-major: row k is ∇φₖ(x)).
    fn entropy_jacobian(x: &[f64], jacobian: &mut [f64]) {
        let n = Self::DIM;
        assert_eq!(
            jacobian.len(),
            Self::entropy_coefficient_count() * n,
            "{}: entropy Jacobian",
            Self::NAME
        );
        jacobian.fill(0.0);
        with_scratch(Self::derivative_monomial_count(), |all| {
            Self::monomials(x, all);
            for &(k, j, a, i) in Self::ENTROPY_JACOBIAN {
                jacobian[k as usize * n + j as usize] = f64::from(a) * all[i as usize];
            }
        });
    }

    /// Metric features φ_s(x) into `features` (`METRIC_EXPONENTS.len()`).
    fn metric_features(x: &[f64], features: &mut [f64]) {
        assert_eq!(
            features.len(),
            Self::METRIC_EXPONENTS.len(),
            "{}: metric features",
            Self::NAME
        );
        Self::monomials(x, features);
    }

    /// S(x) = Σₖ ψₖ φₖ(x) for entropy coefficients ψ
    /// (`ENTROPY_EXPONENTS.len()`), without allocating for paper-sized systems.
    fn entropy_value(x: &[f64], coefficients: &[f64]) -> f64 {
        let p = Self::entropy_coefficient_count();
        assert_eq!(
            coefficients.len(),
            p,
            "{}: entropy coefficients",
            Self::NAME
        );
        with_scratch(p + 1, |all| {
            Self::monomials(x, all);
            all[1..].iter().zip(coefficients).map(|(f, c)| f * c).sum()
        })
    }

    /// ∇S(x) = J(x)ᵀ ψ into `grad` (`DIM`). The macro overrides this with
    /// straight-line code; the provided method walks the Jacobian table.
    fn entropy_gradient(x: &[f64], coefficients: &[f64], grad: &mut [f64]) {
        assert_eq!(
            coefficients.len(),
            Self::entropy_coefficient_count(),
            "{}: entropy coefficients",
            Self::NAME
        );
        assert_eq!(grad.len(), Self::DIM, "{}: entropy gradient", Self::NAME);
        grad.fill(0.0);
        with_scratch(Self::derivative_monomial_count(), |all| {
            Self::monomials(x, all);
            for &(k, j, a, i) in Self::ENTROPY_JACOBIAN {
                grad[j as usize] += coefficients[k as usize] * f64::from(a) * all[i as usize];
            }
        });
    }

    /// K(x) for metric coefficients θ (`metric_coefficient_count()`) into
    /// `metric` (`DIM × DIM`, row-major, both triangles).
    fn metric_value(x: &[f64], coefficients: &[f64], metric: &mut [f64]) {
        let n = Self::DIM;
        let m = Self::METRIC_EXPONENTS.len();
        assert_eq!(
            coefficients.len(),
            Self::metric_coefficient_count(),
            "{}: metric coefficients",
            Self::NAME
        );
        assert_eq!(metric.len(), n * n, "{}: metric", Self::NAME);
        with_scratch(m, |features| {
            Self::monomials(x, features);
            let mut pairs = coefficients.chunks_exact(m);
            for row in 0..n {
                for column in row..n {
                    let theta = pairs.next().unwrap_or_default();
                    let value: f64 = theta.iter().zip(&*features).map(|(t, f)| t * f).sum();
                    metric[row * n + column] = value;
                    metric[column * n + row] = value;
                }
            }
        });
    }

    /// Entropy-search rows of one sample, with the metric fixed.
    ///
    /// Given K(x) in `metric` (`DIM × DIM`), writes M J(x)ᵀ into `block`
    /// (`DIM × ENTROPY_EXPONENTS.len()`, row-major) and M ∇H(x) into `drift`
    /// (`DIM`), where M = Π(x) + K(x). The residual of the sample is then
    /// ẋ − drift − block · ψ, linear in ψ.
    fn entropy_block(x: &[f64], metric: &[f64], block: &mut [f64], drift: &mut [f64]) {
        let n = Self::DIM;
        let p = Self::entropy_coefficient_count();
        assert_eq!(metric.len(), n * n, "{}: metric", Self::NAME);
        assert_eq!(block.len(), n * p, "{}: entropy block", Self::NAME);
        assert_eq!(drift.len(), n, "{}: drift", Self::NAME);
        let derivatives = Self::derivative_monomial_count();
        with_scratch(n * n + n + derivatives, |scratch| {
            let (operator, rest) = scratch.split_at_mut(n * n);
            let (grad_h, all) = rest.split_at_mut(n);
            // M = Π(x) + K(x)
            Self::poisson(x, operator);
            operator.iter_mut().zip(metric).for_each(|(o, k)| *o += k);
            Self::hamiltonian_gradient(x, grad_h);
            for (row, out) in drift.iter_mut().enumerate() {
                *out = dot(&operator[row * n..(row + 1) * n], grad_h);
            }
            // block = M J(x)ᵀ, one sparse Jacobian entry at a time.
            Self::monomials(x, all);
            block.fill(0.0);
            for &(k, j, a, i) in Self::ENTROPY_JACOBIAN {
                let derivative = f64::from(a) * all[i as usize];
                for row in 0..n {
                    block[row * p + k as usize] += operator[row * n + j as usize] * derivative;
                }
            }
        });
    }

    /// Metric-search rows of one sample, with the entropy fixed.
    ///
    /// Given g = ∇H(x) + ∇S(x) in `gradient` (`DIM`), writes the matrix of the
    /// linear map θ ↦ K(x; θ) g into `block` (`DIM × metric_coefficient_count()`,
    /// row-major) and Π(x) g into `drift` (`DIM`). The residual of the sample is
    /// then ẋ − drift − block · θ, linear in θ.
    fn metric_block(x: &[f64], gradient: &[f64], block: &mut [f64], drift: &mut [f64]) {
        let n = Self::DIM;
        let m = Self::METRIC_EXPONENTS.len();
        let width = Self::metric_coefficient_count();
        assert_eq!(gradient.len(), n, "{}: gradient", Self::NAME);
        assert_eq!(block.len(), n * width, "{}: metric block", Self::NAME);
        assert_eq!(drift.len(), n, "{}: drift", Self::NAME);
        with_scratch(n * n + m, |scratch| {
            let (poisson, features) = scratch.split_at_mut(n * n);
            Self::poisson(x, poisson);
            for (row, out) in drift.iter_mut().enumerate() {
                *out = dot(&poisson[row * n..(row + 1) * n], gradient);
            }
            Self::monomials(x, features);
            metric_rows(features, gradient, block);
        });
    }
}

/// The rows of θ ↦ K(θ) g into `block` (`n × n(n+1)/2·m`, row-major) for
/// the metric monomials' values `features` (m) and g = `gradient` (n):
/// θ_jk,a multiplies φ_a g_k in row j and φ_a g_j in row k.
pub(crate) fn metric_rows(features: &[f64], gradient: &[f64], block: &mut [f64]) {
    let (n, m) = (gradient.len(), features.len());
    let width = block.len() / n.max(1);
    block.fill(0.0);
    let mut pair = 0;
    for row in 0..n {
        for column in row..n {
            for (a, feature) in features.iter().enumerate() {
                let coefficient = pair * m + a;
                block[row * width + coefficient] += feature * gradient[column];
                if row != column {
                    block[column * width + coefficient] += feature * gradient[row];
                }
            }
            pair += 1;
        }
    }
}

/// Position of the upper-triangle pair (j, k) (in either order) among the
/// n(n+1)/2 pairs of an n×n symmetric matrix, row-major: the metric
/// coefficients of pair (j, k) occupy `pair * basis_len .. (pair + 1) * basis_len` in θ.
pub(crate) fn metric_pair_index(dim: usize, j: usize, k: usize) -> usize {
    let (j, k) = if j <= k { (j, k) } else { (k, j) };
    // Rows 0..j contribute n, n-1, …, n-j+1 pairs.
    j * dim - j * (j.saturating_sub(1)) / 2 + (k - j)
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Runs `f` on `len` zeroed scratch entries: on the stack up to 256 (the
/// sizes paper-sized systems need), on the heap beyond.
///
/// Tiers keep the zeroing close to `len`. `f` is called from one place, so
/// that it inlines and `len` (a constant of the system) folds: called from
/// one branch per tier, the closure was outlined and the system's monomials
/// were written with a `memcpy` per degree (measured 35 ns against 6 ns for
/// a 2-D metric). The frame stays below one page, so no stack probe.
#[inline(always)]
pub(crate) fn with_scratch<R>(len: usize, f: impl FnOnce(&mut [f64]) -> R) -> R {
    let mut small: [f64; 16];
    let mut medium: [f64; 64];
    let mut large: [f64; 256];
    let mut heap: Vec<f64>;
    let scratch: &mut [f64] = if len <= 16 {
        small = [0.0; 16];
        &mut small[..len]
    } else if len <= 64 {
        medium = [0.0; 64];
        &mut medium[..len]
    } else if len <= 256 {
        large = [0.0; 256];
        &mut large[..len]
    } else {
        heap = vec![0.0; len];
        &mut heap
    };
    f(scratch)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pair_index_enumerates_upper_triangle_row_major() {
        for dim in 1..6 {
            let mut expected = 0;
            for j in 0..dim {
                for k in j..dim {
                    assert_eq!(metric_pair_index(dim, j, k), expected);
                    assert_eq!(metric_pair_index(dim, k, j), expected);
                    expected += 1;
                }
            }
            assert_eq!(expected, dim * (dim + 1) / 2);
        }
    }
}
