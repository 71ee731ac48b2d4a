//! Region certificates and the classical form expand to code that compiles
//! against the runtime's types, with the tables the trait promises.

use metriplectic_runtime::{
    metriplectic, CertificateMode, MetriplecticSystem, Region,
};

metriplectic! {
    /// A state-dependent metric on a ball.
    pub struct OnBall;
    state (q, p);
    const rho = 2;
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 2;
    metric degree 2;
    region ball(center = [0.5, 0], radius = rho);
    reference {
        entropy = -0.5 * (q^2 + p^2);
        metric = [[1 + p^2, -q * p], [-q * p, 1 + q^2]];
    }
}

metriplectic! {
    /// The rigid body in the classical form, certified on a box only.
    pub struct Classical;
    state (x, y, z);
    poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
    hamiltonian = 0.5 * (x^2 + y^2 + z^2);
    entropy degree 4;
    metric degree 2;
    region box(x in [-2, 2], y in [-2, 2], z in [-1, 1]);
    certificate on region;
    relaxation order 1;
    classical;
    reference {
        entropy = -(x^2 + y^2 + z^2);
        metric = [[y^2 + z^2, -x*y, -x*z], [-x*y, x^2 + z^2, -y*z], [-x*z, -y*z, x^2 + y^2]];
    }
}

// State variables named like the generated tables stay variables.
metriplectic! {
    struct Clash;
    state (LOWER_SOS, REGION_TARGETS);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = LOWER_SOS^2 + REGION_TARGETS^2;
    entropy degree 2;
    metric degree 2;
    region ball(radius = 1);
}

fn main() {
    // Inside a function body, where the tables' module is a local item.
    metriplectic! {
        struct Local;
        state (x, y, z);
        poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
        hamiltonian = 0.5 * x^2;
        entropy degree 2;
        metric degree 0;
        region ball(radius = 1);
        classical;
    }
    assert!(Local::REGION_CERTIFICATE.is_some() && Local::CLASSICAL.is_some());

    let ball = OnBall::REGION_CERTIFICATE.expect("a region certificate");
    assert_eq!(ball.region, Region::Ball { center: &[0.5, 0.0], radius: 2.0 });
    assert_eq!(ball.mode, CertificateMode::GlobalLowerBound);
    assert_eq!(ball.relaxation_order, 0);
    assert_eq!(&ball.targets[..OnBall::METRIC_EXPONENTS.len()], OnBall::METRIC_EXPONENTS);
    assert_eq!(ball.lower.len(), 1);
    assert_eq!(ball.upper.len(), 2);
    assert!(ball.lower[0].multiplier.is_empty());
    // g = 4 − (q − 0.5)² − p² = 3.75 + q − q² − p².
    assert_eq!(
        ball.upper[1].multiplier,
        &[(3.75, &[0, 0][..]), (1.0, &[1, 0][..]), (-1.0, &[2, 0][..]), (-1.0, &[0, 2][..])]
    );
    assert!(OnBall::CLASSICAL.is_none());

    let classical = Classical::REGION_CERTIFICATE.expect("a region certificate");
    assert_eq!(classical.mode, CertificateMode::OnRegion);
    assert_eq!(classical.relaxation_order, 1);
    assert_eq!(classical.lower.len(), 4);
    assert_eq!(classical.targets.len(), 35);
    let constraints = Classical::CLASSICAL.expect("classical constraints");
    assert_eq!(constraints.casimir_basis.len(), 2);
    assert_eq!(
        constraints.entropy_constraints.len() + constraints.casimir_basis.len(),
        Classical::ENTROPY_EXPONENTS.len()
    );
    // The reference satisfies every row.
    let psi = Classical::REFERENCE_ENTROPY.unwrap();
    let theta = Classical::REFERENCE_METRIC.unwrap();
    for (rows, values) in [(constraints.entropy_constraints, psi), (constraints.metric_constraints, theta)] {
        for row in rows {
            let value: f64 = row.iter().map(|&(i, c)| c * values[i as usize]).sum();
            assert!(value.abs() < 1e-12, "{value}");
        }
    }

    assert!(Clash::REGION_CERTIFICATE.is_some());
    assert_eq!(Clash::hamiltonian(&[1.0, 2.0]), 5.0);
}
