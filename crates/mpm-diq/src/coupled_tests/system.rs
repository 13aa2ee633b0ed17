//! The coupled system and its conservation: Eq. 35's matrix against the dense Schur
//! complement, total momentum with either interface quadrature, a solids-only plan, and
//! solid–solid penalty contact inside the coupled step.

use super::*;

#[test]
fn coupled_matrix_is_eq35_symmetric_and_positive_definite() {
    let mut s = floating(16, 500.0, 0.5, 0.25, 0.375, true);
    let dt = 2e-3;
    let (rows, inv_mass, _) = s.coupled_problem(dt).unwrap();
    let count = |k: UnknownKind| rows.kinds().iter().filter(|&&x| x == k).count();
    assert!(count(UnknownKind::Fluid) > 50);
    assert!(count(UnknownKind::Wall) > 10);
    assert!(
        count(UnknownKind::SolidPressure) >= 16,
        "4×4 solid cells at least"
    );
    assert!(
        count(UnknownKind::Interface) >= 4,
        "the wetted faces of the block: {} interface rows, {} points",
        count(UnknownKind::Interface),
        s.interface_points().particle.len()
    );
    let mut system = PressureSystem::<2>::new();
    system
        .assemble(&rows, &inv_mass, dt, &PressureParams::default(), &|_| false)
        .unwrap();
    let a = system.matrix().unwrap().to_dense();
    let (n, slots) = (rows.len(), rows.num_nodes());
    let mut j = nalgebra::DMatrix::<Real>::zeros(n, 2 * slots);
    for k in 0..n {
        let (nodes, coeffs) = rows.row(k);
        for (node, r) in nodes.iter().zip(coeffs) {
            for c in 0..2 {
                j[(k, 2 * node + c)] += r[c];
            }
        }
    }
    let minv = nalgebra::DMatrix::<Real>::from_diagonal(&nalgebra::DVector::from_iterator(
        2 * slots,
        (0..2 * slots).map(|i| inv_mass[i / 2]),
    ));
    let compliance = nalgebra::DMatrix::<Real>::from_diagonal(&nalgebra::DVector::from_vec(
        rows.diagonal().to_vec(),
    ));
    let dense = &j * minv * j.transpose() * dt + compliance;
    let scale = dense.amax();
    assert!(
        (&a - &dense).amax() <= 1e-12 * scale,
        "assembled ≠ Δt J M⁻¹ Jᵀ + C"
    );
    assert!(
        (&a - a.transpose()).amax() <= 1e-14 * scale,
        "not symmetric"
    );
    // Eq. 35's zero blocks: solid pressures couple to nothing but solid pressures and
    // interface pressures.
    for k in 0..n {
        for l in 0..n {
            let (kk, kl) = (rows.kinds()[k], rows.kinds()[l]);
            if kk == UnknownKind::SolidPressure
                && matches!(kl, UnknownKind::Fluid | UnknownKind::Wall)
            {
                assert_eq!(a[(k, l)], 0.0, "A1{{2,3}} must vanish");
            }
        }
    }
    // A11 only has the compliance S/Δt on the diagonal beyond Δt G^sᵀ M^s⁻¹ G^s: positive.
    for k in 0..n {
        if rows.kinds()[k] == UnknownKind::SolidPressure {
            assert!(rows.diagonal()[k] > 0.0);
        } else {
            assert_eq!(rows.diagonal()[k], 0.0);
        }
    }
    let eig = nalgebra::SymmetricEigen::new(a).eigenvalues;
    assert!(
        eig.min() > 1e-12 * eig.max(),
        "smallest eigenvalue {:e} (largest {:e})",
        eig.min(),
        eig.max()
    );
}

#[test]
fn total_momentum_of_solid_and_fluid_is_conserved_without_gravity_and_walls() {
    momentum_is_conserved(InterfaceQuadrature::SolidParticles);
}

#[test]
fn total_momentum_is_conserved_with_the_node_interface_rows() {
    momentum_is_conserved(InterfaceQuadrature::FluidNodes);
}

/// A block moving at 0.5 m/s into a blob of water at rest, far from the grid's edges, without
/// gravity and walls: the water is pushed and the total momentum stays to round-off.
fn momentum_is_conserved(interface: InterfaceQuadrature) {
    let spec = open_grid(24);
    let water = lattice(&spec, ([0.45, 0.3], [0.8, 0.7]), (0, RHO_F));
    let block = lattice(&spec, ([0.2, 0.4], [0.4, 0.6]), (1, 800.0));
    let block = block.velocity(Vector::<2>::new(0.5, 0.1));
    let ps = particles_of(&spec, columns(), &[water, block]);
    let mut s = DiqCoupled::new(
        spec,
        params(2e-3, false),
        SolidParams {
            interface,
            ..SolidParams::default()
        },
        materials(800.0, 1e5),
        walls(false),
        ps,
    )
    .unwrap();
    let momentum = |s: &DiqCoupled<2>| {
        let p = s.particles();
        (0..p.len()).fold(Vector::<2>::zeros(), |m, i| m + p.v[i] * p.mass[i])
    };
    let fluid_momentum = |s: &DiqCoupled<2>| {
        let p = s.particles();
        s.fluid_indices()
            .iter()
            .fold(Vector::<2>::zeros(), |m, &i| m + p.v[i] * p.mass[i])
    };
    let p0 = momentum(&s);
    let mut touched = 0;
    for _ in 0..60 {
        let info = s.step().unwrap();
        touched += info
            .events
            .iter()
            .find(|e| e.0 == "interface_points")
            .map_or(0, |e| e.1);
    }
    let p1 = momentum(&s);
    assert!(
        touched > 0 || interface == InterfaceQuadrature::FluidNodes,
        "the block must reach the water"
    );
    assert!(
        fluid_momentum(&s).norm() > 0.02 * p0.norm(),
        "the water must be pushed: {:?}",
        fluid_momentum(&s)
    );
    assert!(
        (p1 - p0).norm() <= 1e-11 * p0.norm(),
        "momentum drift {:e} of {:e}",
        (p1 - p0).norm(),
        p0.norm()
    );
}

#[test]
fn solids_only_plan_has_no_fluid_stage() {
    let spec = tank(16);
    let block = lattice(&spec, ([0.3, 0.3], [0.6, 0.6]), (1, 1000.0));
    let ps = particles_of(&spec, columns(), &[block]);
    let mut s = DiqCoupled::new(
        spec,
        params(2e-3, true),
        SolidParams::default(),
        materials(1000.0, 1e5),
        walls(true),
        ps,
    )
    .unwrap();
    let plan = s.plan().ids();
    for stage in [
        mpm_core::Stage::SORT,
        mpm_core::Stage::GRID_UPDATE,
        crate::stages::POSITION_CORRECTION,
    ] {
        assert!(!plan.contains(&stage), "{stage:?} in a solids-only plan");
    }
    // A falling block without fluid: its centre of mass accelerates at g.
    let com = |s: &DiqCoupled<2>| {
        let p = s.particles();
        (0..p.len()).map(|i| p.v[i][1] * p.mass[i]).sum::<Real>() / p.mass.iter().sum::<Real>()
    };
    let mut t = 0.0;
    for _ in 0..10 {
        t += s.step().unwrap().dt;
    }
    assert!(
        (com(&s) + 9.81 * t).abs() <= 1e-9 * 9.81 * t,
        "{} vs {}",
        com(&s),
        -9.81 * t
    );
}

/// Two elastic blocks approaching at ±0.5 m/s, the right one wetted by a blob of water, no
/// gravity and no walls, and the smallest distance between particles of different blocks over
/// the run relative to `r_p + r_q` (`r_p = ½ (V⁰_p)^{1/2}`, Eq. 4's `FromVolume` radius), with
/// contact on or off. Returns that ratio, the relative momentum drift and the blocks' final
/// relative velocity (m/s, positive when separating).
fn colliding_blocks(contact: bool) -> (Real, Real, Real) {
    let n = 24;
    let dx = 1.0 / n as Real;
    let spec = open_grid(n);
    // Three cells apart, so that the blocks share no node of the reference grid (on one
    // reference grid, bodies closer than the kernel's support are tied through their nodes).
    let (left, right) = (([0.2, 0.4], [0.35, 0.55]), ([0.475, 0.4], [0.625, 0.55]));
    let bodies = [
        lattice(&spec, left, (1, 800.0)).velocity(Vector::<2>::new(0.5, 0.0)),
        lattice(&spec, right, (1, 800.0)).velocity(Vector::<2>::new(-0.5, 0.0)),
        lattice(&spec, ([0.625, 0.3], [0.8, 0.65]), (0, RHO_F)),
    ];
    let mut builder = ParticlesBuilder::with_columns(&spec, &[], columns());
    let ranges: Vec<_> = bodies
        .iter()
        .map(|b| builder.add(b).expect("the body lies inside the grid"))
        .collect();
    // The right block's particles: those of the left one come before, the water's after.
    let (first_right, solids) = (ranges[1].start, ranges[1].end);
    let ps = builder.build();
    let mut solid = SolidParams::<2>::default();
    solid.tlmpm.contact = contact.then(|| mpm_tlmpm::ContactParams {
        radius: mpm_tlmpm::ContactRadius::FromVolume,
        obstacles: Vec::new(),
    });
    let mut s = DiqCoupled::new(
        spec,
        params(2e-3, false),
        solid,
        materials(800.0, 1e5),
        walls(false),
        ps,
    )
    .unwrap();
    let r = 0.5 * (dx / 2.0);
    let momentum = |s: &DiqCoupled<2>| {
        let p = s.particles();
        (0..p.len()).fold(Vector::<2>::zeros(), |m, i| m + p.v[i] * p.mass[i])
    };
    let mean_vx = |s: &DiqCoupled<2>, range: std::ops::Range<usize>| {
        let p = s.particles();
        let len = range.len() as Real;
        range.map(|i| p.v[i][0]).sum::<Real>() / len
    };
    let p0 = momentum(&s);
    let scale: Real = {
        let p = s.particles();
        (0..p.len()).map(|i| p.mass[i] * p.v[i].norm()).sum()
    };
    let mut min_gap = Real::INFINITY;
    while s.time() < 0.3 {
        s.step().unwrap();
        let p = s.particles();
        for a in 0..first_right {
            for b in first_right..solids {
                min_gap = min_gap.min((p.x[a] - p.x[b]).norm() / (2.0 * r));
            }
        }
    }
    let drift = (momentum(&s) - p0).norm() / scale;
    let separating = mean_vx(&s, first_right..solids) - mean_vx(&s, 0..first_right);
    (min_gap, drift, separating)
}

#[test]
fn solid_solid_penalty_contact_acts_inside_the_coupled_step() {
    let (gap, drift, separating) = colliding_blocks(true);
    assert!(gap >= 0.5, "closest pair at {gap} (r_p + r_q)");
    assert!(drift <= 1e-12, "momentum drift {drift:e} of Σ m|v|");
    // Measured: closest pair 0.84 (r_p + r_q), drift 1e-15, separating at 0.58 m/s.
    assert!(
        separating > 0.25,
        "the blocks must bounce: {separating} m/s"
    );
    // Without contact the blocks pass into each other.
    let (gap_off, _, separating_off) = colliding_blocks(false);
    assert!(
        gap_off < 0.25,
        "without contact: closest pair at {gap_off} (r_p + r_q)"
    );
    assert!(
        separating_off < -0.9,
        "without contact they keep approaching: {separating_off}"
    );
}

#[test]
fn a_gravity_ramp_of_the_fluid_or_the_solids_is_rejected() {
    use mpm_core::parameters::GRAVITY_RAMP;
    use mpm_core::quasistatic::GravityRamp;
    use mpm_core::SetupError;
    let ramp = Some(GravityRamp { duration: 0.5 });
    let make = |fluid: DiqParams<2>, solid: SolidParams<2>| {
        let spec = tank(16);
        let water = lattice(&spec, ([0.0, 0.0], [1.0, 0.25]), (0, RHO_F));
        let block = lattice(&spec, ([0.375, 0.5], [0.625, 0.75]), (1, 500.0));
        let ps = particles_of(&spec, columns(), &[water, block]);
        let materials = materials(500.0, 1e5);
        match DiqCoupled::new(spec, fluid, solid, materials, walls(true), ps) {
            Ok(_) => None,
            Err(SetupError::InvalidParameter { name, reason, .. }) => Some((name, reason)),
            Err(other) => panic!("expected an invalid parameter, got {other}"),
        }
    };
    let fluid = params::<2>(5e-3, true);
    assert_eq!(make(fluid.clone(), SolidParams::default()), None);
    let mut ramped = fluid.clone();
    ramped.step.gravity_ramp = ramp;
    let expected = Some((GRAVITY_RAMP, "DIQ has no gravity ramp"));
    assert_eq!(make(ramped, SolidParams::default()), expected);
    let mut solid = SolidParams::default();
    solid.tlmpm.step.gravity_ramp = ramp;
    assert_eq!(make(fluid, solid), expected);
}
