//! Poisson tensors beyond the paper's canonical and so(3)* ones, identified
//! from a cold start: a rigid body in an ideal fluid (Kirchhoff's equations,
//! the Lie–Poisson tensor of se(3)*, six states and two Casimirs) and a
//! log-canonical tensor, quadratic in the state. Both tensors pass the
//! macro's exact Jacobi check; the runtime must then recover fields whose
//! Hamiltonian part is state-dependent in a way the paper's systems are not.

use metriplectic_runtime::prelude::*;

use super::common::reference_trajectories;

metriplectic! {
    /// A rigid body in an ideal fluid (Kirchhoff): angular momentum m and
    /// linear momentum p with Π = −[[m̂, p̂], [p̂, 0]] (the Lie–Poisson tensor
    /// of se(3)*, Casimirs |p|² and m·p) and the kinetic energy of body
    /// and added mass, H = ½ Σ mᵢ²/Iᵢ + ½ Σ pᵢ²/Mᵢ. Viscous drag on both
    /// momenta: E = −H (S = −2H) and a constant diagonal K, so the energy
    /// decays at rate ∇Hᵀ K ∇H. The entropy basis is declared at degree 4,
    /// two above the truth.
    pub struct Kirchhoff;
    state (m1, m2, m3, p1, p2, p3);
    poisson = [
        [0, m3, -m2, 0, p3, -p2],
        [-m3, 0, m1, -p3, 0, p1],
        [m2, -m1, 0, p2, -p1, 0],
        [0, p3, -p2, 0, 0, 0],
        [-p3, 0, p1, 0, 0, 0],
        [p2, -p1, 0, 0, 0, 0]
    ];
    hamiltonian = 0.5 * (m1^2 + m2^2 / 2 + m3^2 / 3) + 0.5 * (p1^2 / 1.5 + p2^2 / 2.5 + p3^2);
    entropy degree 4;
    metric degree 0;
    reference {
        entropy = -(m1^2 + m2^2 / 2 + m3^2 / 3) - (p1^2 / 1.5 + p2^2 / 2.5 + p3^2);
        metric = [
            [0.1, 0, 0, 0, 0, 0],
            [0, 0.1, 0, 0, 0, 0],
            [0, 0, 0.2, 0, 0, 0],
            [0, 0, 0, 0.05, 0, 0],
            [0, 0, 0, 0, 0.05, 0],
            [0, 0, 0, 0, 0, 0.1]
        ];
    }
}

metriplectic! {
    /// A log-canonical tensor Πᵢⱼ = aᵢⱼ xᵢ xⱼ (a Poisson tensor for every
    /// skew-symmetric a, the structure of Lotka–Volterra systems), quadratic
    /// in the state, with a coupled constant metric.
    pub struct LogCanonical;
    state (x, y, z);
    poisson = [[0, x*y, -2*x*z], [-x*y, 0, 0.5*y*z], [2*x*z, -0.5*y*z, 0]];
    hamiltonian = 0.5 * (x^2 + y^2 + z^2);
    entropy degree 4;
    metric degree 0;
    reference {
        entropy = -0.5 * (x^2 + y^2 + z^2) - 0.25 * (x^2 + y^2 + z^2)^2;
        metric = [[0.2, 0.05, 0], [0.05, 0.1, 0], [0, 0, 0.3]];
    }
}

/// Identifies `S` from its reference trajectories with the default
/// configuration and checks the held-out field error and that the fitted
/// free energy never decreases at the held-out states.
fn assert_identified<S: MetriplecticSystem>(tolerance: f64) {
    let data = reference_trajectories::<S>(1.0, 1);
    let fit = identify::<S>(&data.train, &IdentifyConfig::default()).unwrap();
    let truth = Model::<S>::reference().unwrap();
    let held_out = data.held_out.as_ref().unwrap();
    let score = fit.model.compare(&truth, held_out).unwrap();
    assert!(
        score.relative_error <= tolerance,
        "{}: {score:?} after {} iterations ({:?})",
        S::NAME,
        fit.history.iterations.len(),
        fit.stop_reason
    );
    for i in 0..held_out.len() {
        let rate = fit.model.free_energy_rate(held_out.state(i)).unwrap();
        assert!(
            rate >= -1e-12,
            "{}: dE/dt = {rate:e} at sample {i}",
            S::NAME
        );
    }
}

#[test]
fn a_rigid_body_in_an_ideal_fluid_is_identified() {
    assert_identified::<Kirchhoff>(1e-9);
}

#[test]
fn a_log_canonical_tensor_is_identified() {
    assert_identified::<LogCanonical>(1e-9);
}
