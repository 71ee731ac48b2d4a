//! The weak (integral) form: identification from measured states alone.
//!
//! Differentiating noisy samples amplifies their noise (σ/h). Integrating
//! does the opposite. Over a window [a, b] of consecutive samples of one
//! trajectory, with a test function φ that vanishes at both ends,
//! integration by parts turns ẋ = f(x) into
//!
//! ```text
//! −∫ φ′(t) x(t) dt = ∫ φ(t) f(x(t)) dt,
//! ```
//!
//! which needs no derivative, and whose both sides average the noise of
//! many samples. Standing in for x and f(x) between the window's (possibly
//! non-uniform) sample times by local polynomials (see
//! [`WeakForm::local_degree`]) and integrating them against φ and φ′ by
//! Gauss–Legendre quadrature exact for the products gives one equation
//! Σⱼ wⱼ f(xⱼ) = −Σⱼ vⱼ xⱼ, where wⱼ and vⱼ are the integrals of φ and φ′
//! against sample j's cardinal function: linear in the model's coefficients
//! whenever f is, so the entropy search, the metric search and the joint
//! step all run on it unchanged. φ(t) = ((t − a)(b − t))^p, normalised to
//! unit integral, so that an equation's target is a weighted mean of ẋ over
//! the window and weak and pointwise data have comparable scales.

use serde::{Deserialize, Serialize};

use super::equations::{joined_names, sealed, Equations, IdentificationData, Terms};
use super::trajectory::{describe, in_series};
use super::Trajectory;
use crate::error::{invalid, Result};

/// How trajectories are cut into weak-form windows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WeakForm {
    /// Samples per window (≥ 3; the test function vanishes at both ends).
    /// Default 15.
    pub window: usize,
    /// Samples between the starts of consecutive windows (≥ 1). Default 1:
    /// overlapping windows use every sample in many equations, which on
    /// noisy data beats fewer, disjoint windows (see the noise study in the
    /// README) at the price of more equations.
    pub stride: usize,
    /// Exponent p of the test function ((t − a)(b − t))^p (≥ 2, so that φ
    /// and φ′ vanish at both ends, at most 16). Default 4.
    pub power: u32,
    /// Degree d of the local polynomials that stand for x(t) and f(x(t))
    /// between samples (1 to 7, less than `window`). d = 1 interpolates
    /// linearly; d ≥ 2 fits, on each interval, the least-squares polynomial
    /// of degree d to the 2(d + 1) nearest samples of the window (all of
    /// them if fewer). The quadrature error is O(h^(d+1)), which matters on
    /// sparse grids: on the paper's log-uniform samples linear interpolation
    /// alone limits the fit to about 1e-2. Least squares rather than
    /// interpolation, because random sample times put some samples very
    /// close together, where an interpolating polynomial's weights (and the
    /// noise) blow up like 1/spacing. Default 2: on noisy data the quadratic
    /// fit smooths more than the cubic (held-out error 9e-3 against 2e-2 on
    /// the paper's 2-D data with 1% state noise); on clean sparse data the
    /// cubic is about twice as accurate.
    pub local_degree: usize,
}

impl Default for WeakForm {
    fn default() -> Self {
        Self {
            window: 15,
            stride: 1,
            power: 4,
            local_degree: 2,
        }
    }
}

impl WeakForm {
    /// Checks the window, stride and power.
    pub fn validate(&self) -> Result<()> {
        if self.window < 3 {
            return Err(invalid(
                "weak-form window",
                format!("{} samples: a window needs at least 3", self.window),
            ));
        }
        if self.stride == 0 {
            return Err(invalid("weak-form stride", "must be at least 1"));
        }
        if !(1..=7).contains(&self.local_degree) || self.local_degree >= self.window {
            return Err(invalid(
                "weak-form local degree",
                format!(
                    "{}: must be between 1 and 7 and less than the window ({} samples)",
                    self.local_degree, self.window
                ),
            ));
        }
        if self.power > 16 {
            return Err(invalid(
                "weak-form power",
                format!(
                    "{}: at most 16 (higher powers concentrate the test function on a few samples)",
                    self.power
                ),
            ));
        }
        if self.power < 2 {
            return Err(invalid(
                "weak-form power",
                format!(
                    "{}: the test function and its derivative must vanish at the window's ends; use 2 or more",
                    self.power
                ),
            ));
        }
        Ok(())
    }
}

/// Weak-form identification data: one equation per window of each
/// trajectory (see the module documentation of the method in
/// [`WeakDataset::from_trajectories`]).
///
/// ```
/// use metriplectic_runtime::{Trajectory, WeakDataset, WeakForm, IdentificationData};
///
/// let t: Vec<f64> = (0..40).map(|k| 0.05 * k as f64).collect();
/// let x: Vec<f64> = t.iter().flat_map(|t| [t.cos(), -t.sin()]).collect();
/// let traj = Trajectory::new(vec!["q".into(), "p".into()], t, x, None).unwrap();
/// let data = WeakDataset::from_trajectories(&[traj], &WeakForm::default()).unwrap();
/// // Windows of 15 samples start at samples 0, 1, …, 25 (stride 1).
/// assert_eq!(data.equation_count(), 26);
/// // Named by the trajectories: identification checks the system's names.
/// assert_eq!(data.state_names().unwrap(), ["q", "p"]);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct WeakDataset {
    dim: usize,
    states: Vec<f64>,
    targets: Vec<f64>,
    offsets: Vec<usize>,
    samples: Vec<usize>,
    weights: Vec<f64>,
    names: Option<Vec<String>>,
    /// The same targets with local polynomials of a neighbouring degree
    /// (`degrees.1`), or empty: how far they move is the quadrature's
    /// uncertainty ([`WeakDataset::quadrature_spread`]).
    alternative: Vec<f64>,
    /// The local degree of `targets` and of `alternative`.
    degrees: (usize, usize),
}

impl WeakDataset {
    /// The weak-form equations of `trajectories` (same state names, states
    /// only; derivatives, if present, are ignored).
    ///
    /// Each trajectory gives a window starting at samples 0, stride,
    /// 2·stride, … while it fits (samples after the last whole window are
    /// not used). With
    /// φ(t) = ((t − a)(b − t))^p / ∫((t − a)(b − t))^p dt on the window
    /// [a, b] and the cardinal functions ℓⱼ of the local polynomials of
    /// degree `form.local_degree` through its samples, the equation is
    /// Σⱼ (∫φℓⱼ) f(xⱼ) = −Σⱼ (∫φ′ℓⱼ) xⱼ — the weak form of ẋ = f(x), no
    /// derivative estimate, both sides averaging the states' noise. The
    /// targets are formed a second time with the neighbouring local degree
    /// for [`quadrature_spread`](Self::quadrature_spread), which doubles
    /// this construction's (linear, small beside a fit's) work.
    ///
    /// Errors if there is no trajectory, the trajectories' state names differ
    /// (in name or order), the form is invalid, or a trajectory is shorter
    /// than the window (it would give no equation).
    pub fn from_trajectories(trajectories: &[Trajectory], form: &WeakForm) -> Result<Self> {
        let mut data = Self::build(trajectories, form)?;
        // The targets again with the neighbouring local degree, for the
        // quadrature's uncertainty: a degree above where the window allows
        // one, else below.
        let d = form.local_degree;
        let other = if d < 7 && d + 1 < form.window {
            d + 1
        } else {
            d - 1
        };
        if other >= 1 && other != d {
            let alternative = WeakForm {
                local_degree: other,
                ..*form
            };
            if let Ok(again) = Self::build(trajectories, &alternative) {
                data.alternative = again.targets;
                data.degrees = (d, other);
            }
        }
        Ok(data)
    }

    /// How much the equations' targets move between the local degree of
    /// [`WeakForm::local_degree`] and its neighbour: Σ|Δy|/Σ|y| over every
    /// component, with the two degrees. On sparse samples the local
    /// polynomials miss what happens between samples, and the equations,
    /// and so any model fitted to them, are no more accurate than this
    /// (with noisy states it includes how differently the two degrees
    /// smooth the noise). `None` for a dataset without a second degree.
    pub fn quadrature_spread(&self) -> Option<(f64, usize, usize)> {
        if self.alternative.len() != self.targets.len() || self.targets.is_empty() {
            return None;
        }
        let size: f64 = self.targets.iter().map(|y| y.abs()).sum();
        let moved: f64 = self
            .targets
            .iter()
            .zip(&self.alternative)
            .map(|(y, z)| (y - z).abs())
            .sum();
        let spread = if size > 0.0 { moved / size } else { 0.0 };
        spread
            .is_finite()
            .then_some((spread, self.degrees.0, self.degrees.1))
    }

    /// [`from_trajectories`](Self::from_trajectories) with `form` alone.
    fn build(trajectories: &[Trajectory], form: &WeakForm) -> Result<Self> {
        form.validate()?;
        let first = trajectories
            .first()
            .ok_or_else(|| invalid("trajectories", "at least one trajectory is required"))?;
        super::trajectory::check_same_names(trajectories)?;
        let dim = first.dim();
        let longest = trajectories.iter().map(Trajectory::len).max().unwrap_or(0);
        if longest < form.window {
            return Err(invalid(
                "weak-form window",
                format!(
                    "{} samples, but no trajectory is that long (the longest has {longest})",
                    form.window
                ),
            ));
        }
        // A trajectory without a whole window would give no equation: its
        // samples would be dropped without a word.
        if let Some((index, short)) = trajectories
            .iter()
            .enumerate()
            .find(|(_, trajectory)| trajectory.len() < form.window)
        {
            return Err(invalid(
                "weak-form window",
                format!(
                    "{} samples, but {} has only {}, so none of its samples would be used; \
                     shorten the window or leave that trajectory out",
                    form.window,
                    describe(index, short),
                    short.len()
                ),
            ));
        }
        let mut data = Self::empty(dim);
        data.names = Some(first.names().to_vec());
        for (index, trajectory) in trajectories.iter().enumerate() {
            let base = data.states.len() / dim;
            data.states.extend_from_slice(trajectory.states());
            let times = trajectory.times();
            // Checked: a stride or window near usize::MAX means "one window".
            let mut start = 0_usize;
            while start
                .checked_add(form.window)
                .is_some_and(|end| end <= times.len())
            {
                data.push_window(trajectory, base, start, form)
                    .map_err(|err| in_series(err, &describe(index, trajectory)))?;
                let Some(next) = start.checked_add(form.stride) else {
                    break;
                };
                start = next;
            }
        }
        data.drop_unused_samples();
        Ok(data)
    }

    /// No equations, in dimension `dim`.
    fn empty(dim: usize) -> Self {
        Self {
            dim,
            states: Vec::new(),
            targets: Vec::new(),
            offsets: vec![0],
            samples: Vec::new(),
            weights: Vec::new(),
            names: None,
            alternative: Vec::new(),
            degrees: (0, 0),
        }
    }

    /// Appends the equation of the window of `trajectory` starting at
    /// sample `start` (its samples stored from `base`).
    fn push_window(
        &mut self,
        trajectory: &Trajectory,
        base: usize,
        start: usize,
        form: &WeakForm,
    ) -> Result<()> {
        let n = self.dim;
        let times = &trajectory.times()[start..start + form.window];
        let (a, b) = (times[0], times[times.len() - 1]);
        let p = form.power as i32;
        // φ(t) = u^p with u = (t − a)(b − t)/half² ∈ [0, 1], and φ′; the
        // weights and slopes are divided by ∫φ below, so the scale is
        // free. Unscaled, ((t − a)(b − t))^16 overflowed for windows of
        // 1e11 time units (nanosecond stamps 10 s apart) and underflowed
        // at spacings of 1e-30 (a probe).
        let half = 0.5 * (b - a);
        let u = |t: f64| ((t - a) / half) * ((b - t) / half);
        let phi = |t: f64| u(t).powi(p);
        let dphi =
            |t: f64| f64::from(form.power) * u(t).powi(p - 1) * (((a + b - 2.0 * t) / half) / half);
        // Product integration: x and f(x) are represented between samples
        // by local polynomials of degree d, and φ and φ′ are integrated
        // exactly against them (Gauss–Legendre with enough points for
        // degree 2p + d), so the only error is the local polynomials',
        // O(h^(d+1)), however uneven the sample times.
        let d = form.local_degree;
        let rule = gauss_legendre((2 * form.power as usize + d) / 2 + 1);
        let count = if d == 1 {
            2
        } else {
            (2 * (d + 1)).min(times.len())
        };
        let mut weights = vec![0.0; times.len()];
        let mut slopes = vec![0.0; times.len()];
        let mut integral = 0.0;
        for k in 0..times.len() - 1 {
            let (left, right) = (times[k], times[k + 1]);
            let h = right - left;
            // The `count` samples nearest the interval, inside the window.
            let first = (k + 1).saturating_sub(count / 2).min(times.len() - count);
            let local = LocalPolynomial::new(&times[first..first + count], d, left)?;
            for &(node, weight) in &rule {
                let t = left + 0.5 * h * (node + 1.0);
                let w = 0.5 * h * weight;
                let (phi, dphi) = (w * phi(t), w * dphi(t));
                for (j, l) in local.basis(t).enumerate() {
                    weights[first + j] += phi * l;
                    slopes[first + j] += dphi * l;
                }
                integral += phi;
            }
        }
        if !(integral.is_finite() && integral > 0.0) {
            return Err(invalid(
                "time spacing",
                format!(
                    "the weak-form window of samples {start}..={} (t = {a:e} … {b:e}) has no usable \
                     test-function integral ({integral:e}); the times are too close together or too far apart",
                    start + form.window - 1
                ),
            ));
        }
        let mut target = vec![0.0; n];
        let first_weight = self.weights.len();
        // Σⱼ φ′ⱼ = ∫φ′ = 0, so the target is formed from xⱼ − x₀: an offset
        // (a temperature of 300 ± 2) no longer leaves its rounding in it,
        // and states at rest give a target of exactly 0 (it was 3e-15, which
        // the fit and the warnings read as signal; a probe).
        let origin = trajectory.state(start);
        for (j, (weight, slope)) in weights.iter().zip(&slopes).enumerate() {
            let x = trajectory.state(start + j);
            let slope = -slope / integral;
            target
                .iter_mut()
                .zip(x.iter().zip(origin))
                .for_each(|(y, (v, o))| *y += slope * (v - o));
            let weight = weight / integral;
            if weight != 0.0 {
                self.samples.push(base + start + j);
                self.weights.push(weight);
            }
        }
        // Σ slope·(x − x₀) overflows for states f64::MAX apart, and the weights for
        // extreme time spacings: say so rather than store inf or NaN.
        if let Some((component, value)) = target.iter().enumerate().find(|(_, y)| !y.is_finite()) {
            return Err(invalid(
                "weak-form target",
                format!(
                    "component {component} of the window of samples {start}..={} (t = {a:e} … {b:e}) \
                     is {value} (states too far apart for Σ φ′ⱼ(xⱼ − x₀) to be represented)",
                    start + form.window - 1
                ),
            ));
        }
        if let Some(value) = self.weights[first_weight..].iter().find(|w| !w.is_finite()) {
            return Err(invalid(
                "time spacing",
                format!(
                    "the weak-form window of samples {start}..={} (t = {a:e} … {b:e}) has a quadrature \
                     weight {value}; the times are too close together or too far apart",
                    start + form.window - 1
                ),
            ));
        }
        self.targets.extend(target);
        self.offsets.push(self.samples.len());
        Ok(())
    }

    /// Keeps only the samples some equation reads, renumbered in order.
    fn drop_unused_samples(&mut self) {
        let n = self.dim;
        let count = self.states.len() / n;
        let mut used = vec![usize::MAX; count];
        let mut states = Vec::new();
        for sample in &mut self.samples {
            if used[*sample] == usize::MAX {
                used[*sample] = states.len() / n;
                states.extend_from_slice(&self.states[*sample * n..(*sample + 1) * n]);
            }
            *sample = used[*sample];
        }
        self.states = states;
    }

    /// The states the equations read, row-major.
    pub fn states(&self) -> &[f64] {
        &self.states
    }

    /// The targets −Σⱼ (∫φ′ℓⱼ) xⱼ, n per equation (see
    /// [`from_trajectories`](Self::from_trajectories)).
    pub fn targets(&self) -> &[f64] {
        &self.targets
    }
}

/// The least-squares polynomial of degree d through samples at `nodes`
/// (an interpolant when there are d + 1), as weights on the samples: its
/// value at t is Σⱼ ℓⱼ(t) yⱼ.
struct LocalPolynomial {
    /// Rows: monomial k of u = (t − centre)/scale; columns: samples.
    pseudo_inverse: nalgebra::DMatrix<f64>,
    centre: f64,
    scale: f64,
}

impl LocalPolynomial {
    fn new(nodes: &[f64], degree: usize, centre: f64) -> Result<Self> {
        // Centred abscissae scaled by the farthest node lie in [−1, 1]: the
        // Vandermonde matrix stays well conditioned and finite however
        // uneven the spacing (scaling by one interval's length overflowed
        // when that interval was tiny against the others).
        let scale = nodes
            .iter()
            .fold(0.0_f64, |m, &t| m.max((t - centre).abs()));
        if !(scale.is_finite() && scale > 0.0) {
            return Err(invalid(
                "time spacing",
                format!(
                    "the samples at t = {:e} … {:e} span {scale:e}, which a local polynomial cannot be fitted over",
                    nodes.first().copied().unwrap_or(centre),
                    nodes.last().copied().unwrap_or(centre)
                ),
            ));
        }
        let vandermonde = nalgebra::DMatrix::from_fn(nodes.len(), degree + 1, |r, c| {
            ((nodes[r] - centre) / scale).powi(c as i32)
        });
        let pseudo_inverse = vandermonde
            .svd(true, true)
            .pseudo_inverse(1e-13)
            .map_err(|reason| invalid("weak-form local polynomial", reason.to_owned()))?;
        Ok(Self {
            pseudo_inverse,
            centre,
            scale,
        })
    }

    /// ℓⱼ(t) for every sample j.
    fn basis(&self, t: f64) -> impl Iterator<Item = f64> + '_ {
        let u = (t - self.centre) / self.scale;
        self.pseudo_inverse.column_iter().map(move |column| {
            column
                .iter()
                .rev()
                .fold(0.0, |value, coefficient| value * u + coefficient)
        })
    }
}

/// Nodes and weights of `count`-point Gauss–Legendre quadrature on [−1, 1]
/// (exact for polynomials of degree < 2·count): Newton's method on the
/// Legendre recurrence from Chebyshev-like starting points.
fn gauss_legendre(count: usize) -> Vec<(f64, f64)> {
    let n = count as f64;
    (0..count)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n + 0.5)).cos();
            let mut derivative = 1.0;
            for _ in 0..100 {
                // P_count(x) and its derivative by the three-term recurrence.
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=count {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
                }
                derivative = n * (x * p1 - p0) / (x * x - 1.0);
                let step = p1 / derivative;
                x -= step;
                if step.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * derivative * derivative))
        })
        .collect()
}

impl sealed::Sealed for WeakDataset {
    fn equations(&self) -> Equations<'_> {
        Equations {
            dim: self.dim,
            states: &self.states,
            targets: &self.targets,
            terms: Some(Terms {
                offsets: &self.offsets,
                samples: &self.samples,
                weights: &self.weights,
            }),
            names: self.names.as_deref(),
        }
    }

    fn select(&self, indices: &[usize]) -> Result<Self> {
        // As `Dataset::select`: data without equations fit anything.
        if indices.is_empty() {
            return Err(invalid("equation indices", "at least one is required"));
        }
        let count = self.targets.len() / self.dim;
        if let Some(&bad) = indices.iter().find(|&&e| e >= count) {
            return Err(invalid(
                "equation index",
                format!("{bad} is out of range for {count} weak-form equations"),
            ));
        }
        let n = self.dim;
        let mut out = Self {
            dim: n,
            states: self.states.clone(),
            targets: Vec::with_capacity(indices.len() * n),
            offsets: vec![0],
            samples: Vec::new(),
            weights: Vec::new(),
            names: self.names.clone(),
            alternative: Vec::new(),
            degrees: self.degrees,
        };
        let alternative = self.alternative.len() == self.targets.len();
        for &e in indices {
            out.targets
                .extend_from_slice(&self.targets[e * n..(e + 1) * n]);
            if alternative {
                out.alternative
                    .extend_from_slice(&self.alternative[e * n..(e + 1) * n]);
            }
            let range = self.offsets[e]..self.offsets[e + 1];
            out.samples.extend_from_slice(&self.samples[range.clone()]);
            out.weights.extend_from_slice(&self.weights[range]);
            out.offsets.push(out.samples.len());
        }
        out.drop_unused_samples();
        Ok(out)
    }

    fn concat(parts: &[&Self]) -> Result<Self> {
        let first = parts
            .first()
            .ok_or_else(|| invalid("weak-form datasets", "at least one is required"))?;
        let dim = first.dim;
        let mut all = Self::empty(dim);
        // The spread is kept only where every part has it, at one pair of
        // degrees.
        let alternative = parts.iter().all(|part| {
            part.alternative.len() == part.targets.len() && part.degrees == first.degrees
        });
        all.degrees = first.degrees;
        for (index, part) in parts.iter().enumerate() {
            if part.dim != dim {
                return Err(invalid(
                    "weak-form datasets",
                    format!(
                        "dataset {index} has {} state variables, dataset 0 has {dim}",
                        part.dim
                    ),
                ));
            }
            all.names = joined_names(
                &all.names,
                &part.names,
                "weak-form datasets",
                ("dataset 0", &format!("dataset {index}")),
            )?;
            let (base, start) = (all.states.len() / dim, all.samples.len());
            all.states.extend_from_slice(&part.states);
            all.targets.extend_from_slice(&part.targets);
            if alternative {
                all.alternative.extend_from_slice(&part.alternative);
            }
            all.samples.extend(part.samples.iter().map(|s| s + base));
            all.weights.extend_from_slice(&part.weights);
            all.offsets
                .extend(part.offsets[1..].iter().map(|o| o + start));
        }
        Ok(all)
    }
}

impl IdentificationData for WeakDataset {
    fn quadrature_spread(&self) -> Option<(f64, usize, usize)> {
        WeakDataset::quadrature_spread(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::equations::sealed::Sealed;

    #[test]
    fn concatenated_parts_equal_the_dataset_of_all_trajectories() {
        let trajectory = |phase: f64, count: usize| {
            let t: Vec<f64> = (0..count).map(|k| 0.05 * k as f64).collect();
            let x = t
                .iter()
                .flat_map(|t| [(t + phase).cos(), -(t + phase).sin()])
                .collect();
            Trajectory::new(vec!["q".into(), "p".into()], t, x, None).unwrap()
        };
        let all = [
            trajectory(0.0, 40),
            trajectory(1.0, 33),
            trajectory(2.0, 50),
        ];
        let form = WeakForm::default();
        let whole = WeakDataset::from_trajectories(&all, &form).unwrap();
        let parts: Vec<WeakDataset> = all
            .iter()
            .map(|t| WeakDataset::from_trajectories(std::slice::from_ref(t), &form).unwrap())
            .collect();
        let joined = WeakDataset::concat(&parts.iter().collect::<Vec<_>>()).unwrap();
        assert_eq!(joined, whole);
        // Both keep the targets of the neighbouring local degree: the
        // quadrature's spread of a selection of all equations, or of the
        // parts joined, is the whole dataset's.
        let spread = whole.quadrature_spread().unwrap();
        assert_eq!((spread.1, spread.2), (2, 3));
        assert!(spread.0 > 0.0 && spread.0 < 1e-3, "{spread:?}");
        assert_eq!(joined.quadrature_spread(), Some(spread));
        let all_equations: Vec<usize> = (0..whole.equation_count()).collect();
        assert_eq!(
            whole.select(&all_equations).unwrap().quadrature_spread(),
            Some(spread)
        );
        // Repeats are allowed (a bootstrap draws a part twice).
        let twice = WeakDataset::concat(&[&parts[1], &parts[1]]).unwrap();
        assert_eq!(twice.equation_count(), 2 * parts[1].equation_count());
        assert!(WeakDataset::concat(&[]).is_err());
    }

    /// The largest residual of the weak equations of x(t) = (cos t, −sin t),
    /// which solves ẋ = (x₂, −x₁), sampled at `count` uneven times on [0, 3].
    fn largest_residual(count: usize, form: &WeakForm) -> f64 {
        // Windows of a fixed duration, a quarter of the trajectory.
        let form = &WeakForm {
            window: count / 4,
            stride: count / 8,
            ..*form
        };
        let h = 3.0 / count as f64;
        let t: Vec<f64> = (0..count)
            .map(|k| h * k as f64 + 0.3 * h * (k as f64).sin())
            .collect();
        let x: Vec<f64> = t.iter().flat_map(|t| [t.cos(), -t.sin()]).collect();
        let traj = Trajectory::new(vec!["q".into(), "p".into()], t, x, None).unwrap();
        let data = WeakDataset::from_trajectories(&[traj], form).unwrap();
        let equations = data.equations();
        let mut largest: f64 = 0.0;
        for e in 0..equations.len() {
            let mut lhs = [0.0; 2];
            for (j, w) in equations.terms_of(e) {
                let x = equations.state(j);
                lhs[0] += w * x[1];
                lhs[1] -= w * x[0];
            }
            let target = equations.target(e);
            largest = largest.max((lhs[0] - target[0]).abs().max((lhs[1] - target[1]).abs()));
        }
        largest
    }

    /// Every weak equation holds for the true field up to the quadrature
    /// error, which falls like h^(d+1) with the interpolation degree d.
    #[test]
    fn weak_equations_hold_for_the_true_field_to_the_interpolation_order() {
        for (degree, order) in [(1, 2.0), (2, 3.0), (3, 4.0)] {
            let form = WeakForm {
                local_degree: degree,
                ..WeakForm::default()
            };
            let (coarse, fine) = (largest_residual(60, &form), largest_residual(120, &form));
            let observed = (coarse / fine).log2();
            assert!(
                observed > order - 0.5,
                "degree {degree}: residual {coarse:e} -> {fine:e}, order {observed:.2}"
            );
        }
        // At the default degree 2 the residual (relative to |ẋ| = 1) is a
        // quadrature error below h³ (h = 0.05 here), not an error in the
        // weights' construction (which would not shrink with h).
        let h: f64 = 3.0 / 60.0;
        let residual = largest_residual(60, &WeakForm::default());
        assert!(residual < h.powi(3), "{residual:e}");
    }

    #[test]
    fn gauss_legendre_integrates_its_degree_exactly() {
        let rule = gauss_legendre(5);
        let table = [0.906_179_845_938_664, 0.538_469_310_105_683, 0.0];
        for x in table {
            assert!(rule.iter().any(|(node, _)| (node.abs() - x).abs() < 1e-14));
        }
        for count in [3, 6, 11] {
            let rule = gauss_legendre(count);
            for degree in 0..2 * count {
                let exact = if degree % 2 == 1 {
                    0.0
                } else {
                    2.0 / (degree + 1) as f64
                };
                let sum: f64 = rule.iter().map(|(x, w)| w * x.powi(degree as i32)).sum();
                assert!(
                    (sum - exact).abs() < 1e-13,
                    "{count} points, degree {degree}: {sum}"
                );
            }
        }
    }

    #[test]
    fn selecting_equations_keeps_their_targets() {
        let t: Vec<f64> = (0..60).map(|k| 0.05 * k as f64).collect();
        let x: Vec<f64> = t.iter().flat_map(|t| [t.cos(), -t.sin()]).collect();
        let traj = Trajectory::new(vec!["q".into(), "p".into()], t, x, None).unwrap();
        let data = WeakDataset::from_trajectories(&[traj], &WeakForm::default()).unwrap();
        let equations = data.equations();
        let picked = data.select(&[2, 0]).unwrap();
        assert_eq!(picked.equations().target(1), equations.target(0));
        assert_eq!(picked.equations().target(0), equations.target(2));
        assert!(data.select(&[99]).is_err());
        let err = data.select(&[]).unwrap_err();
        assert!(
            err.to_string().contains("at least one is required"),
            "{err}"
        );
        assert_eq!(
            picked.state_names(),
            Some(&["q".to_owned(), "p".to_owned()][..])
        );
    }

    #[test]
    fn bad_forms_and_short_trajectories_are_errors() {
        let traj = Trajectory::new(vec!["x".into()], vec![0.0, 1.0], vec![1.0, 2.0], None).unwrap();
        assert!(
            WeakDataset::from_trajectories(std::slice::from_ref(&traj), &WeakForm::default())
                .is_err()
        );
        for form in [
            WeakForm {
                window: 2,
                ..WeakForm::default()
            },
            WeakForm {
                stride: 0,
                ..WeakForm::default()
            },
            WeakForm {
                power: 1,
                ..WeakForm::default()
            },
            WeakForm {
                power: 17,
                ..WeakForm::default()
            },
            WeakForm {
                local_degree: 0,
                ..WeakForm::default()
            },
            WeakForm {
                window: 4,
                local_degree: 4,
                ..WeakForm::default()
            },
        ] {
            assert!(WeakDataset::from_trajectories(std::slice::from_ref(&traj), &form).is_err());
        }
        assert!(WeakDataset::from_trajectories(&[], &WeakForm::default()).is_err());

        let t: Vec<f64> = (0..40).map(|k| 0.05 * k as f64).collect();
        let qp = circle(t.clone(), 1.0);
        let states = qp.states().to_vec();
        let pq = Trajectory::new(vec!["p".into(), "q".into()], t, states, None).unwrap();
        let err = WeakDataset::from_trajectories(&[qp, pq], &WeakForm::default()).unwrap_err();
        assert!(err.to_string().contains("trajectory 1 has (p, q)"), "{err}");
    }

    #[test]
    fn a_trajectory_shorter_than_the_window_is_named_not_dropped() {
        let long: Vec<f64> = (0..40).map(|k| 0.05 * k as f64).collect();
        let short: Vec<f64> = (0..10).map(|k| 0.05 * k as f64).collect();
        let err = WeakDataset::from_trajectories(
            &[
                circle(long.clone(), 1.0),
                circle(short, 1.0),
                circle(long, 1.0),
            ],
            &WeakForm::default(),
        )
        .unwrap_err();
        assert!(
            err.to_string().contains(
                "15 samples, but trajectory 1 has only 10, so none of its samples would be used"
            ),
            "{err}"
        );
    }

    fn circle(t: Vec<f64>, radius: f64) -> Trajectory {
        let x = t
            .iter()
            .flat_map(|t| [radius * t.cos(), -radius * t.sin()])
            .collect();
        Trajectory::new(vec!["q".into(), "p".into()], t, x, None).unwrap()
    }

    #[test]
    fn a_stride_or_window_near_the_integer_limit_means_one_window() {
        let t: Vec<f64> = (0..40).map(|k| 0.05 * k as f64).collect();
        let one = WeakDataset::from_trajectories(
            &[circle(t.clone(), 1.0), circle(t, 1.0)],
            &WeakForm {
                stride: usize::MAX,
                ..WeakForm::default()
            },
        )
        .unwrap();
        assert_eq!(one.equation_count(), 2);
        let t: Vec<f64> = (0..40).map(|k| 0.05 * k as f64).collect();
        let error = WeakDataset::from_trajectories(
            &[circle(t, 1.0)],
            &WeakForm {
                window: usize::MAX,
                local_degree: 2,
                ..WeakForm::default()
            },
        )
        .unwrap_err();
        assert!(error.to_string().contains("window"), "{error}");
    }

    #[test]
    fn extreme_spacings_and_states_give_finite_equations_or_an_error() {
        // One interval 1e-160 long among intervals of 1: the local
        // polynomials are scaled by their farthest node, so nothing
        // overflows and every equation is finite.
        let mut t = vec![0.0, 1e-160];
        t.extend((1..30).map(f64::from));
        let data = WeakDataset::from_trajectories(&[circle(t, 1.0)], &WeakForm::default())
            .expect("uneven but finite spacing");
        assert!(data.targets().iter().all(|v| v.is_finite()));
        assert!(data.weights.iter().all(|v| v.is_finite()));
        // States near f64::MAX on a smooth path give finite targets (the
        // sum runs over differences to the window's first state)…
        let t: Vec<f64> = (0..40).map(|k| 0.05 * k as f64).collect();
        let data =
            WeakDataset::from_trajectories(&[circle(t.clone(), 1e308)], &WeakForm::default())
                .unwrap();
        assert!(data.targets().iter().all(|v| v.is_finite()));
        // …but a jump across it overflows Σ φ′(x − x₀), and that is an error
        // naming the quantity, not an infinite target.
        let x: Vec<f64> = (0..40)
            .flat_map(|k| [if k < 20 { 1.7e308 } else { -1.7e308 }, 0.0])
            .collect();
        let jump = Trajectory::new(vec!["q".into(), "p".into()], t, x, None).unwrap();
        let error = WeakDataset::from_trajectories(&[jump], &WeakForm::default()).unwrap_err();
        assert!(error.to_string().contains("weak-form target"), "{error}");
    }

    /// The test function is scaled to [0, 1] on each window: with power 16
    /// a probe's spacing of 1e10 (nanosecond stamps 10 s apart) had "no
    /// usable test-function integral (inf)", and 1e-30 underflowed. The
    /// equations are the same in any time unit: targets scale by 1/h.
    #[test]
    fn equations_do_not_depend_on_the_time_unit() {
        let form = WeakForm {
            power: 16,
            ..WeakForm::default()
        };
        let unit: Vec<f64> = (0..40).map(|k| 0.05 * k as f64).collect();
        let reference =
            WeakDataset::from_trajectories(&[circle(unit.clone(), 1.0)], &form).unwrap();
        for h in [1e10, 1e-30, 1e150] {
            // The same states, at times in another unit.
            let circle = circle(unit.clone(), 1.0);
            let t: Vec<f64> = unit.iter().map(|t| t * h).collect();
            let scaled =
                Trajectory::new(circle.names().to_vec(), t, circle.states().to_vec(), None)
                    .unwrap();
            let data = WeakDataset::from_trajectories(&[scaled], &form).unwrap();
            for (a, b) in data.targets().iter().zip(reference.targets()) {
                assert!(
                    (a * h - b).abs() <= 1e-9 * (1.0 + b.abs()),
                    "h = {h:e}: {} vs {b}",
                    a * h
                );
            }
            for (a, b) in data.weights.iter().zip(&reference.weights) {
                assert!(
                    (a - b).abs() <= 1e-9 * (1.0 + b.abs()),
                    "h = {h:e}: {a} vs {b}"
                );
            }
        }
    }

    /// Targets are formed from differences to the window's first state:
    /// an offset changes nothing, and states at rest give exactly 0.
    #[test]
    fn offsets_leave_the_targets_unchanged_and_rest_gives_zero() {
        let t: Vec<f64> = (0..40).map(|k| 0.05 * k as f64).collect();
        let base = circle(t.clone(), 1.0);
        let reference =
            WeakDataset::from_trajectories(std::slice::from_ref(&base), &WeakForm::default())
                .unwrap();
        let shifted: Vec<f64> = base.states().iter().map(|x| x + 1e8).collect();
        let offset = Trajectory::new(base.names().to_vec(), t.clone(), shifted, None).unwrap();
        let data = WeakDataset::from_trajectories(&[offset], &WeakForm::default()).unwrap();
        for (a, b) in data.targets().iter().zip(reference.targets()) {
            // Only the states' own rounding at 1e8 (1.5e-8) remains.
            assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        }
        let rest = Trajectory::new(base.names().to_vec(), t, vec![0.3; 80], None).unwrap();
        let data = WeakDataset::from_trajectories(&[rest], &WeakForm::default()).unwrap();
        assert!(
            data.targets().iter().all(|y| *y == 0.0),
            "{:?}",
            data.targets()
        );
    }
}
