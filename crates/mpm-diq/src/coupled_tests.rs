//! Tests of the coupled solver: Eq. 35's matrix, momentum, buoyancy, determinism and resume.

use crate::coupled::{DiqCoupled, InterfaceQuadrature, SolidParams};
use crate::fluid::DiqParams;
use crate::pressure::{PressureParams, PressureSystem, UnknownKind};
use mpm_core::boundary::{Boundaries, Contact, DomainWalls};
use mpm_core::material::{ElasticModel, FluidMaterial, Lame, SolidMaterial, Tait};
use mpm_core::{
    Columns, GridSpec, Material, ParticleInit, Particles, Real, Solver, TimeStepPolicy, Vector,
};

const RHO_F: Real = 1000.0;

fn materials(rho_s: Real, young: Real) -> Vec<Material> {
    vec![
        Material::Fluid(FluidMaterial {
            density: RHO_F,
            eos: Tait {
                bulk_modulus: 2e6,
                gamma: 7.0,
            },
            viscosity: 0.0,
        }),
        Material::Solid(SolidMaterial {
            density: rho_s,
            elastic: ElasticModel::NeoHookean(Lame::from_young_poisson(young, 0.3)),
            plasticity: Default::default(),
        }),
    ]
}

/// A lattice of 2 particles per cell and axis over `[lo, hi]`, keeping the points where
/// `keep(x)`, of material `material` with density `rho` and velocity `v`.
fn lattice<const D: usize>(
    ps: &mut Particles<D>,
    (lo, hi): ([Real; D], [Real; D]),
    dx: Real,
    (material, rho): (u32, Real),
    v: Vector<D>,
    keep: impl Fn(&Vector<D>) -> bool,
) {
    let h = dx / 2.0;
    let counts: [usize; D] = std::array::from_fn(|a| ((hi[a] - lo[a]) / h).round() as usize);
    for i in 0..counts.iter().product() {
        let mut rest = i;
        let x = Vector::<D>::from_fn(|a, _| {
            let k = rest % counts[a];
            rest /= counts[a];
            lo[a] + (k as Real + 0.5) * h
        });
        if keep(&x) {
            ps.push(ParticleInit {
                x,
                v,
                mass: rho * h.powi(D as i32),
                volume0: h.powi(D as i32),
                material,
                affine: mpm_core::Matrix::<D>::zeros(),
            });
        }
    }
}

fn params<const D: usize>(dt_max: Real, gravity: bool) -> DiqParams<D> {
    let mut p = DiqParams::<D> {
        time_step: TimeStepPolicy::Adaptive {
            cfl: 0.4,
            dt_max,
            dt_min: 1e-9,
        },
        pressure: PressureParams {
            rel_tol: 1e-10,
            ..PressureParams::default()
        },
        ..DiqParams::default()
    };
    if !gravity {
        p.gravity = Vector::<D>::zeros();
    }
    p
}

fn walls<const D: usize>(on: bool) -> Boundaries<D> {
    Boundaries {
        walls: on.then_some(DomainWalls {
            contact: Contact::default(),
            thickness: 1,
            treatment: Default::default(),
        }),
        colliders: Vec::new(),
    }
}

fn columns() -> Columns {
    Columns {
        deformation_gradient: true,
        ..Columns::default()
    }
}

/// A 1 m × 1 m tank of `n` cells per axis with water up to `depth` and a square elastic block
/// of side `side` and density `rho_s` whose bottom sits at `bottom`, centred in x.
fn floating(
    n: usize,
    rho_s: Real,
    depth: Real,
    side: Real,
    bottom: Real,
    corr: bool,
) -> DiqCoupled<2> {
    let dx = 1.0 / n as Real;
    let (x0, x1) = (0.5 - side / 2.0, 0.5 + side / 2.0);
    let inside = move |x: &Vector<2>| {
        x[0] > x0 - 0.25 * dx && x[0] < x1 + 0.25 * dx && x[1] > bottom - 0.25 * dx
    };
    let mut ps = Particles::new(columns());
    lattice(
        &mut ps,
        ([0.0, 0.0], [1.0, depth]),
        dx,
        (0, RHO_F),
        Vector::<2>::zeros(),
        |x| !inside(x),
    );
    lattice(
        &mut ps,
        ([x0, bottom], [x1, bottom + side]),
        dx,
        (1, rho_s),
        Vector::<2>::zeros(),
        |_| true,
    );
    DiqCoupled::new(
        GridSpec::new(Vector::<2>::from_element(-dx), dx, [n + 3, n + 3]),
        DiqParams {
            position_correction: corr,
            ..params(5e-3, true)
        },
        SolidParams::default(),
        materials(rho_s, 1e5),
        walls(true),
        ps,
    )
    .unwrap()
}

/// Eq. 4 penalty contact of the solid with the unit tank's walls (as `mpm-cli` gives a scene's
/// walls to its solids).
fn tank_walls() -> Option<mpm_tlmpm::ContactParams<2>> {
    Some(mpm_tlmpm::ContactParams {
        radius: mpm_tlmpm::ContactRadius::FromVolume,
        obstacles: vec![mpm_tlmpm::Obstacle::Walls {
            min: Vector::<2>::zeros(),
            max: Vector::<2>::from_element(1.0),
        }],
    })
}

/// The lowest solid particle's height (m).
fn lowest(s: &DiqCoupled<2>) -> Real {
    let p = s.particles();
    s.solid_indices()
        .iter()
        .map(|&i| p.x[i][1])
        .fold(Real::INFINITY, Real::min)
}

#[test]
fn coupled_matrix_is_eq35_symmetric_and_positive_definite() {
    let mut s = floating(16, 500.0, 0.5, 0.25, 0.375, true);
    let dt = 2e-3;
    let (rows, inv_mass, _) = s.coupled_problem(dt).unwrap();
    let count = |k: UnknownKind| rows.kinds.iter().filter(|&&x| x == k).count();
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
    let (n, slots) = (rows.len(), rows.num_nodes);
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
        rows.diagonal.clone(),
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
            let (kk, kl) = (rows.kinds[k], rows.kinds[l]);
            if kk == UnknownKind::SolidPressure
                && matches!(kl, UnknownKind::Fluid | UnknownKind::Wall)
            {
                assert_eq!(a[(k, l)], 0.0, "A1{{2,3}} must vanish");
            }
        }
    }
    // A11 only has the compliance S/Δt on the diagonal beyond Δt G^sᵀ M^s⁻¹ G^s: positive.
    for k in 0..n {
        if rows.kinds[k] == UnknownKind::SolidPressure {
            assert!(rows.diagonal[k] > 0.0);
        } else {
            assert_eq!(rows.diagonal[k], 0.0);
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
    let n = 24;
    let dx = 1.0 / n as Real;
    let mut ps = Particles::new(columns());
    lattice(
        &mut ps,
        ([0.45, 0.3], [0.8, 0.7]),
        dx,
        (0, RHO_F),
        Vector::<2>::zeros(),
        |_| true,
    );
    lattice(
        &mut ps,
        ([0.2, 0.4], [0.4, 0.6]),
        dx,
        (1, 800.0),
        Vector::<2>::new(0.5, 0.1),
        |_| true,
    );
    let mut s = DiqCoupled::new(
        GridSpec::new(Vector::<2>::zeros(), dx, [n + 1, n + 1]),
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

/// Runs `make()` for `2 · steps` steps with 1 and with 2 threads, and resumed from the
/// checkpoint after `steps` steps; asserts that the three end states are bitwise identical and
/// returns the resumed solver.
fn assert_bitwise_across_threads_and_resume(
    make: impl Fn() -> DiqCoupled<2> + Sync,
    steps: u64,
) -> DiqCoupled<2> {
    let run = |threads: usize| {
        crate::tests::with_threads(threads, || {
            let mut s = make();
            for _ in 0..steps {
                s.step().unwrap();
            }
            let mid = s.checkpoint();
            for _ in 0..steps {
                s.step().unwrap();
            }
            (mid, s.checkpoint())
        })
    };
    let (mid1, end1) = run(1);
    let (_, end2) = run(2);
    assert_eq!(end1, end2, "1 vs 2 threads");
    let mut resumed = make();
    resumed.restore(&mid1).unwrap();
    assert_eq!(resumed.steps(), steps);
    for _ in 0..steps {
        resumed.step().unwrap();
    }
    assert_eq!(resumed.checkpoint(), end1, "resume from checkpoint");
    resumed
}

/// A square block of side 0.25 m (E = `young` Pa, density `ratio` × the water's) held in the
/// middle of a 1 m tank filled with still water to 0.75 m (its top 0.25 m under the surface),
/// at `n` cells per metre; clamped (every reference node fixed) or free.
fn submerged(
    n: usize,
    (young, ratio): (Real, Real),
    clamped: bool,
    interface: InterfaceQuadrature,
) -> DiqCoupled<2> {
    let dx = 1.0 / n as Real;
    let (lo, hi) = ([0.375, 0.25], [0.625, 0.5]);
    let inside = |x: &Vector<2>| (0..2).all(|a| x[a] > lo[a] && x[a] < hi[a]);
    let mut ps = Particles::new(columns());
    let still = Vector::<2>::zeros();
    lattice(
        &mut ps,
        ([0.0, 0.0], [1.0, 0.75]),
        dx,
        (0, RHO_F),
        still,
        |x| !inside(x),
    );
    lattice(&mut ps, (lo, hi), dx, (1, ratio * RHO_F), still, |_| true);
    let mut tlmpm = mpm_tlmpm::TlmpmParams {
        contact: tank_walls(),
        ..mpm_tlmpm::TlmpmParams::default()
    };
    if clamped {
        tlmpm.fixed = vec![mpm_tlmpm::FixedRegion::clamp(
            Vector::<2>::new(lo[0] - 2.0 * dx, lo[1] - 2.0 * dx),
            Vector::<2>::new(hi[0] + 2.0 * dx, hi[1] + 2.0 * dx),
        )];
    }
    DiqCoupled::new(
        GridSpec::new(Vector::<2>::from_element(-dx), dx, [n + 3, n + 3]),
        params(5e-3, true),
        SolidParams {
            interface,
            tlmpm,
            ..SolidParams::default()
        },
        materials(ratio * RHO_F, young),
        walls(true),
        ps,
    )
    .unwrap()
}

/// The fastest water particle (m/s) and the block's mean vertical velocity (m/s).
fn water_and_block_speed(s: &DiqCoupled<2>) -> (Real, Real) {
    let p = s.particles();
    let fastest = s
        .fluid_indices()
        .iter()
        .map(|&i| p.v[i].norm())
        .fold(0.0, Real::max);
    let solid = s.solid_indices();
    let mass: Real = solid.iter().map(|&i| p.mass[i]).sum();
    let vy = solid.iter().map(|&i| p.mass[i] * p.v[i][1]).sum::<Real>() / mass;
    (fastest, vy)
}

#[test]
fn still_water_around_a_clamped_block_stays_at_rest_with_the_node_interface_rows() {
    // Water at rest beside a solid is a discrete equilibrium only with the node rows: there
    // the hydrostatic pressure balances gravity at every node to round-off, while the paper's
    // quadrature sets the water beside the block moving within a step.
    let steps = |interface| {
        let mut s = submerged(16, (1e8, 1.0), true, interface);
        for _ in 0..5 {
            s.step().unwrap();
        }
        water_and_block_speed(&s).0
    };
    let nodes = steps(InterfaceQuadrature::FluidNodes);
    let paper = steps(InterfaceQuadrature::SolidParticles);
    assert!(nodes < 1e-9, "node rows: water at {nodes:e} m/s");
    assert!(paper > 1e-3, "paper's rows: water at {paper:e} m/s");
}

#[test]
fn a_neutrally_buoyant_stiff_block_stays_put_with_the_node_interface_rows() {
    // Released at rest, fully submerged, ρs = ρf: buoyancy equals weight. With the paper's
    // quadrature it sinks (at 4-11 % of g, docs/diq.md); with the node rows it stays.
    let run = |interface| {
        let mut s = submerged(16, (1e8, 1.0), false, interface);
        while s.time() < 0.25 {
            s.step().unwrap();
        }
        water_and_block_speed(&s)
    };
    let (water, block) = run(InterfaceQuadrature::FluidNodes);
    let (_, paper) = run(InterfaceQuadrature::SolidParticles);
    assert!(water < 1e-4, "water at {water:e} m/s");
    assert!(block.abs() < 1e-4, "block at {block:e} m/s");
    // Sinking at 2 % of g for 0.25 s would be 0.049 m/s; measured 0.092 m/s.
    assert!(
        paper < -0.02 * 9.81 * 0.25,
        "paper's rows: block at {paper:e} m/s"
    );
}

#[test]
fn node_interface_rows_are_bitwise_across_threads_and_resume() {
    assert_bitwise_across_threads_and_resume(
        || submerged(16, (1e5, 0.8), false, InterfaceQuadrature::FluidNodes),
        6,
    );
}

#[test]
fn bitwise_identical_across_threads_and_resume() {
    let resumed =
        assert_bitwise_across_threads_and_resume(|| floating(16, 750.0, 0.5, 0.25, 0.375, true), 8);
    // The solid pressure is part of the state: it is non-zero after the block was loaded.
    assert!(resumed.solid_pressure().iter().any(|&p| p.abs() > 1.0));
}

#[test]
fn solids_only_plan_has_no_fluid_stage() {
    let dx = 1.0 / 16.0;
    let mut ps = Particles::new(columns());
    lattice(
        &mut ps,
        ([0.3, 0.3], [0.6, 0.6]),
        dx,
        (1, 1000.0),
        Vector::<2>::zeros(),
        |_| true,
    );
    let mut s = DiqCoupled::new(
        GridSpec::new(Vector::<2>::from_element(-dx), dx, [19, 19]),
        params(2e-3, true),
        SolidParams::default(),
        materials(1000.0, 1e5),
        walls(true),
        ps,
    )
    .unwrap();
    let plan = s.plan().ids();
    for stage in [
        mpm_core::Stage::Sort,
        mpm_core::Stage::GridUpdate,
        mpm_core::Stage::PositionCorrection,
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

#[test]
fn fluid_does_not_enter_a_slab_resting_on_it() {
    // An elastic slab across the whole 2D tank rests on 0.5 m of water: the water is trapped,
    // so the slab must stay where it is and no fluid particle may end inside it (IQ-MPM's
    // position clamping; without it the water rose 0.19 m into the slab within 1 s).
    let n = 16;
    let dx = 1.0 / n as Real;
    let (bottom, thick) = (0.5, 0.25);
    let mut ps = Particles::new(columns());
    lattice(
        &mut ps,
        ([0.0, 0.0], [1.0, bottom]),
        dx,
        (0, RHO_F),
        Vector::<2>::zeros(),
        |_| true,
    );
    lattice(
        &mut ps,
        ([0.0, bottom], [1.0, bottom + thick]),
        dx,
        (1, 500.0),
        Vector::<2>::zeros(),
        |_| true,
    );
    let mut s = DiqCoupled::new(
        GridSpec::new(Vector::<2>::from_element(-dx), dx, [n + 3, n + 3]),
        params(5e-3, true),
        SolidParams::default(),
        materials(500.0, 1e5),
        walls(true),
        ps,
    )
    .unwrap();
    let start = lowest(&s);
    while s.time() < 0.5 {
        s.step().unwrap();
    }
    let p = s.particles();
    let top_fluid = s
        .fluid_indices()
        .iter()
        .map(|&i| p.x[i][1])
        .fold(Real::NEG_INFINITY, Real::max);
    let sag = start - lowest(&s);
    assert!(sag.abs() <= 0.25 * dx, "the slab moved by {sag} m");
    assert!(
        top_fluid <= bottom + 0.5 * dx,
        "fluid reached {top_fluid} m, into the slab from {bottom} m"
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
    let mut ps = Particles::new(columns());
    // Three cells apart, so that the blocks share no node of the reference grid (on one
    // reference grid, bodies closer than the kernel's support are tied through their nodes).
    let (left, right) = (([0.2, 0.4], [0.35, 0.55]), ([0.475, 0.4], [0.625, 0.55]));
    lattice(
        &mut ps,
        left,
        dx,
        (1, 800.0),
        Vector::<2>::new(0.5, 0.0),
        |_| true,
    );
    let first_right = ps.len();
    lattice(
        &mut ps,
        right,
        dx,
        (1, 800.0),
        Vector::<2>::new(-0.5, 0.0),
        |_| true,
    );
    let solids = ps.len();
    lattice(
        &mut ps,
        ([0.625, 0.3], [0.8, 0.65]),
        dx,
        (0, RHO_F),
        Vector::<2>::zeros(),
        |_| true,
    );
    let mut solid = SolidParams::<2>::default();
    solid.tlmpm.contact = contact.then(|| mpm_tlmpm::ContactParams {
        radius: mpm_tlmpm::ContactRadius::FromVolume,
        obstacles: Vec::new(),
    });
    let mut s = DiqCoupled::new(
        GridSpec::new(Vector::<2>::zeros(), dx, [n + 1, n + 1]),
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
fn a_block_sinks_onto_the_tank_floor_and_stays_above_it() {
    // ρs = 2000 kg/m² in 0.4 m of water: the block sinks, and the walls, obstacles of Eq. 4's
    // solid–boundary contact, hold it on the floor y = 0.
    let n = 16;
    let dx = 1.0 / n as Real;
    let (x0, x1, bottom) = (0.375, 0.625, 0.125);
    let inside = |x: &Vector<2>| x[0] > x0 && x[0] < x1 && x[1] > bottom;
    let mut ps = Particles::new(columns());
    lattice(
        &mut ps,
        ([0.0, 0.0], [1.0, 0.4]),
        dx,
        (0, RHO_F),
        Vector::<2>::zeros(),
        |x| !inside(x),
    );
    lattice(
        &mut ps,
        ([x0, bottom], [x1, bottom + 0.25]),
        dx,
        (1, 2000.0),
        Vector::<2>::zeros(),
        |_| true,
    );
    let mut solid = SolidParams::<2>::default();
    solid.tlmpm.contact = tank_walls();
    let mut s = DiqCoupled::new(
        GridSpec::new(Vector::<2>::from_element(-dx), dx, [n + 3, n + 3]),
        params(5e-3, true),
        solid,
        materials(2000.0, 1e5),
        walls(true),
        ps,
    )
    .unwrap();
    let mean_vy = |s: &DiqCoupled<2>| {
        let p = s.particles();
        let ids = s.solid_indices();
        ids.iter().map(|&i| p.v[i][1]).sum::<Real>() / ids.len() as Real
    };
    let mut deepest = Real::INFINITY;
    let mut fastest: Real = 0.0;
    while s.time() < 1.0 {
        s.step().unwrap();
        deepest = deepest.min(lowest(&s));
        fastest = fastest.max(-mean_vy(&s));
    }
    // The lowest row starts h/2 = dx/4 above its cell's bottom, 0.125 m up; it must land
    // (come within a cell of the floor) without passing its centre through y = 0.
    assert!(
        deepest < dx,
        "the block never reached the floor: {deepest} m"
    );
    assert!(
        deepest > 0.0,
        "a solid particle went through the floor: {deepest} m"
    );
    assert!(fastest > 0.1, "it must have sunk: {fastest} m/s at most");
    assert!(
        mean_vy(&s).abs() < 0.1 * fastest,
        "resting on the floor: mean vy {} m/s (fastest sinking {fastest} m/s)",
        mean_vy(&s)
    );
}

/// A 1 m tank at Δx = 1/16 m with water up to `water_top` (m) and a block over `block` (m)
/// of density `rho_s` (kg/m²) and Young's modulus `young` (Pa), moving at `v` (m/s), its
/// solid integrated with `solid`; adaptive steps of at most 3 ms.
fn dropped_block(
    water_top: Real,
    block: ([Real; 2], [Real; 2]),
    (rho_s, young): (Real, Real),
    v: Vector<2>,
    solid: SolidParams<2>,
) -> DiqCoupled<2> {
    let n = 16;
    let dx = 1.0 / n as Real;
    let mut ps = Particles::new(columns());
    let water = ([0.0, 0.0], [1.0, water_top]);
    lattice(&mut ps, water, dx, (0, RHO_F), Vector::<2>::zeros(), |_| {
        true
    });
    lattice(&mut ps, block, dx, (1, rho_s), v, |_| true);
    DiqCoupled::new(
        GridSpec::new(Vector::<2>::from_element(-dx), dx, [n + 3, n + 3]),
        params(3e-3, true),
        solid,
        materials(rho_s, young),
        walls(true),
        ps,
    )
    .unwrap()
}

/// A block of E = `young` (ρs/ρf = 0.7) dropped from 0.1 m into 0.4 m of water, with
/// `passes` coupled projections per step at most; the tank's walls hold it (Eq. 4).
fn stiff_drop(young: Real, passes: usize) -> DiqCoupled<2> {
    let mut solid = SolidParams::<2>::default();
    solid.coupling.max_passes = passes;
    solid.tlmpm.contact = tank_walls();
    let block = ([0.375, 0.5], [0.625, 0.75]);
    dropped_block(0.4, block, (700.0, young), Vector::<2>::zeros(), solid)
}

/// The largest Green strain `‖FᵀF − I‖` of a solid particle.
fn largest_strain(s: &DiqCoupled<2>) -> Real {
    let p = s.particles();
    s.solid_indices()
        .iter()
        .map(|&q| {
            let f = p.def_grad_of(q);
            (f.transpose() * f - mpm_core::Matrix::<2>::identity()).norm()
        })
        .fold(0.0, Real::max)
}

#[test]
fn a_stiff_block_hitting_water_stays_rigid_with_the_coupling_iteration() {
    // E = 1 GPa: the water's pressure strains it by about 1e-6. With the paper's one-pass
    // split, each impact leaves the interface nodes with their own impulse: a strain of
    // |Δv| dt/dx ≈ 1.3 · 3e-3 · 16 = 0.06 in one step, and 6.6 times the system's energy
    // within 0.6 s in the stability sweep.
    let mut worst = [0.0 as Real; 2];
    for (k, passes) in [1usize, 50].into_iter().enumerate() {
        let mut s = stiff_drop(1e9, passes);
        let mut wet = false;
        while s.time() < 0.3 {
            let info = s.step().unwrap();
            wet |= info
                .events
                .iter()
                .any(|&(name, n)| name == "interface_points" && n > 0);
            worst[k] = worst[k].max(largest_strain(&s));
            if passes > 1 {
                let it = info.solves.iter().find(|i| i.name == "coupling_passes");
                let it = it.expect("the coupled step reports its passes");
                assert!(it.iterations <= 50 && it.residual <= 1e-5, "{it:?}");
            }
        }
        assert!(wet, "the block reached the water");
    }
    assert!(worst[0] > 0.02, "one pass: {}", worst[0]);
    assert!(worst[1] < 1e-4, "iterated: {}", worst[1]);
}

#[test]
fn a_solid_leaving_the_fluid_box_is_no_interface_point() {
    // Without wall obstacles a heavy block falls through the tank's floor; the fluid grid has
    // no cells below it, so its particles must drop out of the interface quadrature instead of
    // stopping the step (it panicked in the binning before).
    let dx = 1.0 / 16.0;
    let block = ([0.375, 0.3], [0.625, 0.55]);
    let v = Vector::<2>::new(0.0, -3.0);
    let mut s = dropped_block(0.25, block, (5000.0, 1e5), v, SolidParams::default());
    let mut below = false;
    while s.time() < 0.5 && !below {
        s.step().unwrap();
        let p = s.particles();
        below = s.solid_indices().iter().any(|&q| p.x[q][1] < -dx);
    }
    assert!(below, "the block left the box through the floor");
    // Every interface point lies inside the fluid's box.
    let p = s.particles();
    let iq = s.interface_points();
    let ids = s.solid_indices();
    assert!(iq.particle.iter().all(|&k| p.x[ids[k]][1] >= -dx));
}

/// A soft A-ULMPM block (E = 1e4 Pa, trigger ε = 1e-3, η = 0.01) moving at 0.5 m/s into a blob
/// of water at rest, without gravity or walls.
fn aulmpm_collision() -> DiqCoupled<2> {
    collision(true)
}

/// [`aulmpm_collision`], with A-ULMPM when `adaptive`, else total Lagrangian.
fn collision(adaptive: bool) -> DiqCoupled<2> {
    let n = 24;
    let dx = 1.0 / n as Real;
    let mut ps = Particles::new(columns());
    let blob = ([0.45, 0.3], [0.8, 0.7]);
    lattice(&mut ps, blob, dx, (0, RHO_F), Vector::<2>::zeros(), |_| {
        true
    });
    let v = Vector::<2>::new(0.5, 0.1);
    lattice(&mut ps, ([0.2, 0.4], [0.4, 0.6]), dx, (1, 800.0), v, |_| {
        true
    });
    let mut solid = SolidParams::<2>::default();
    solid.tlmpm.reference_update = adaptive.then_some(mpm_tlmpm::ReferenceUpdate {
        epsilon: 1e-3,
        eta: 0.01,
    });
    DiqCoupled::new(
        GridSpec::new(Vector::<2>::zeros(), dx, [n + 1, n + 1]),
        params(2e-3, false),
        solid,
        materials(800.0, 1e4),
        walls(false),
        ps,
    )
    .unwrap()
}

#[test]
fn a_ulmpm_solid_updates_its_reference_in_water_and_conserves_momentum() {
    let mut s = aulmpm_collision();
    let momentum = |s: &DiqCoupled<2>| {
        let p = s.particles();
        (0..p.len()).fold(Vector::<2>::zeros(), |m, i| m + p.v[i] * p.mass[i])
    };
    let p0 = momentum(&s);
    let (mut updates, mut touched, mut drift) = (0u64, 0u64, 0.0 as Real);
    for _ in 0..60 {
        let info = s.step().unwrap();
        for &(name, n) in &info.events {
            match name {
                "reference_updates" => updates += n,
                "interface_points" => touched += n,
                _ => {}
            }
        }
        drift = drift.max((momentum(&s) - p0).norm() / p0.norm());
    }
    assert!(touched > 0, "the block reached the water");
    assert!(updates >= 2, "the reference moved {updates} times");
    assert_eq!(s.solid().reference_updates(), updates);
    // Eq. 37's volume term restarts at each update; momentum stays conserved to round-off.
    assert!(drift <= 1e-11, "momentum drift {drift:e}");
    // An elastic solid moves as with a fixed reference: the same run in total Lagrangian form.
    let mut tl = collision(false);
    for _ in 0..60 {
        tl.step().unwrap();
    }
    let (a, b) = (s.particles(), tl.particles());
    let (mut dx, mut dj) = (0.0 as Real, 0.0 as Real);
    for &q in s.solid_indices() {
        dx = dx.max((a.x[q] - b.x[q]).norm());
        let det = |f: mpm_core::Matrix<2>| f.determinant();
        dj = dj.max((det(a.def_grad_of(q)) - det(b.def_grad_of(q))).abs());
    }
    // Measured: 6.0e-4 m (0.014 cell) and 0.015. The J difference is Eq. 37's: the volume
    // term restarts from J^(r,n) = 1 at each update, so between updates the block is softer in
    // volume by the mixed part λ^v = λ/2 of its stiffness.
    assert!(dx < 0.1 / 24.0 && dj < 0.02, "{dx:e} m, {dj:e}");
}

#[test]
fn a_ulmpm_coupled_run_is_bitwise_across_threads_and_a_resume_after_an_update() {
    let run = |threads: usize| {
        crate::tests::with_threads(threads, || {
            let mut s = aulmpm_collision();
            while s.solid().reference_updates() == 0 {
                s.step().unwrap();
            }
            let mid = s.checkpoint();
            for _ in 0..10 {
                s.step().unwrap();
            }
            (mid, s.checkpoint(), s.solid().reference_updates())
        })
    };
    let (mid1, end1, updates) = run(1);
    let (_, end2, _) = run(2);
    assert_eq!(end1, end2, "1 vs 2 threads");
    let mut resumed = aulmpm_collision();
    resumed.restore(&mid1).unwrap();
    assert_eq!(resumed.solid().reference_updates(), 1);
    for _ in 0..10 {
        resumed.step().unwrap();
    }
    assert_eq!(resumed.checkpoint(), end1, "resume from checkpoint");
    assert_eq!(resumed.solid().reference_updates(), updates);
}

/// A soil block (Table 1's soil: snow-type clamped stretches θ_c = 2.5e-2, θ_s = 7.5e-3, no
/// hardening, E = 1.4e5 Pa, ν = 0.2, 400 kg/m³) dilating at 25 s⁻¹ without gravity, fluid or
/// walls, A-ULMPM with trigger `epsilon`.
fn dilating_soil(epsilon: Real) -> DiqCoupled<2> {
    let n = 24;
    let dx = 1.0 / n as Real;
    let mut ps = Particles::new(Columns {
        plastic: true,
        ..columns()
    });
    let c = Vector::<2>::new(0.5, 0.5);
    lattice(&mut ps, ([0.4, 0.4], [0.6, 0.6]), dx, (0, 400.0), c, |_| {
        true
    });
    for p in 0..ps.len() {
        ps.v[p] = (ps.x[p] - c) * 25.0;
    }
    let soil = Material::Solid(SolidMaterial {
        density: 400.0,
        elastic: ElasticModel::NeoHookean(Lame::from_young_poisson(1.4e5, 0.2)),
        plasticity: mpm_core::material::Plasticity::Snow(mpm_core::material::Snow {
            theta_c: 2.5e-2,
            theta_s: 7.5e-3,
            hardening: 0.0,
        }),
    });
    let mut solid = SolidParams::<2>::default();
    solid.tlmpm.reference_update = Some(mpm_tlmpm::ReferenceUpdate { epsilon, eta: 0.01 });
    DiqCoupled::new(
        GridSpec::new(Vector::<2>::zeros(), dx, [n + 1, n + 1]),
        params(2e-3, false),
        solid,
        vec![soil],
        walls(false),
        ps,
    )
    .unwrap()
}

/// The mean and the largest gap between each soil particle's remapped `1 − P^s/λ^v` and its
/// elastic volume ratio `det F_E`, and the largest `det F_E`.
fn remap_gap(s: &DiqCoupled<2>) -> (Real, Real, Real) {
    let p = s.particles();
    let jac = s.solid_jacobian();
    let (mut sum, mut gap, mut top) = (0.0 as Real, 0.0 as Real, 0.0 as Real);
    for (&q, j) in s.solid_indices().iter().zip(&jac) {
        let je = p.def_grad_of(q).determinant();
        sum += (j - je).abs();
        gap = gap.max((j - je).abs());
        top = top.max(je);
    }
    (sum / jac.len() as Real, gap, top)
}

#[test]
fn plastic_flow_moves_the_soil_pressure_with_the_elastic_volume() {
    // A 5 %-per-step dilation against stretches clamped at 1 + 7.5e-3: nearly all of it is
    // plastic. Without the correction P ← λ^v − r (λ^v − P), 1 − P/λ^v follows the kinematic
    // J of its cell (measured: mean gap to det F_E 0.037, largest 0.058 after one step) while
    // det F_E stays below (1.0075)² ≈ 1.015. With it the gap is what is left of the cell-wise
    // pressure against particle-wise return mappings (measured: mean 3.7e-3, largest 0.012).
    let mut s = dilating_soil(1.0);
    s.step().unwrap();
    let (mean, gap, top) = remap_gap(&s);
    assert!(top <= 1.0075f64.powi(2) + 1e-12, "det F_E {top}");
    assert!(
        mean < 6e-3 && gap < 0.02,
        "remap gap after one step {mean:e}, {gap:e}"
    );
    // With A-ULMPM updating the reference every step the pressure is not reset (a reset
    // would put 1 − P/λ^v at 1, a mean gap of about det F_E − 1 ≈ 0.013).
    let mut s = dilating_soil(1e-4);
    let mut updates = 0;
    for _ in 0..5 {
        let info = s.step().unwrap();
        updates += info
            .events
            .iter()
            .filter(|(name, _)| *name == "reference_updates")
            .map(|(_, n)| n)
            .sum::<u64>();
        let (mean, gap, _) = remap_gap(&s);
        assert!(
            mean < 6e-3 && gap < 0.02,
            "remap gap {mean:e}, {gap:e} after {updates} updates"
        );
    }
    assert!(updates >= 4, "{updates} reference updates");
}

#[test]
fn plastic_coupled_run_is_bitwise_across_threads_and_a_resume() {
    // The soil block with a reference update every step: the corrected P^s, the plastic state
    // and the base F^(0,r) all go through the checkpoint.
    let resumed = assert_bitwise_across_threads_and_resume(|| dilating_soil(1e-4), 3);
    assert!(resumed.solid().reference_updates() >= 4);
}

#[test]
fn node_rows_hold_the_normal_on_faces_and_both_axes_at_corners() {
    // The clamped block of the test above, its faces on grid lines (Δx = 1/16 m): each node
    // on a face gets one interface row (its normal; the fluid slips along the face), each of
    // the four corner nodes two (a hydrostatic pressure needs both there).
    let n = 16;
    let dx = 1.0 / n as Real;
    let mut s = submerged(n, (1e8, 1.0), true, InterfaceQuadrature::FluidNodes);
    let (rows, _, _) = s.coupled_problem(5e-3).unwrap();
    let spec = GridSpec::<2>::new(Vector::<2>::from_element(-dx), dx, [n + 3, n + 3]);
    let mut count = std::collections::BTreeMap::<usize, usize>::new();
    for (k, kind) in rows.kinds.iter().enumerate() {
        if *kind == UnknownKind::Interface {
            *count.entry(rows.anchors[k]).or_default() += 1;
        }
    }
    let (lo, hi) = ([0.375, 0.25], [0.625, 0.5]);
    let near = |a: Real, b: Real| (a - b).abs() < 1e-9;
    for (&node, &c) in &count {
        let x = spec.node_position(&spec.multi_index(node));
        let on_x = near(x[0], lo[0]) || near(x[0], hi[0]);
        let on_y = near(x[1], lo[1]) || near(x[1], hi[1]);
        let inside = (0..2).all(|a| x[a] > lo[a] - 1e-9 && x[a] < hi[a] + 1e-9);
        assert!(inside && (on_x || on_y), "a row off the block at {x:?}");
        let expected = if on_x && on_y { 2 } else { 1 };
        assert_eq!(c, expected, "{c} interface rows at {x:?}");
    }
    // 3 face nodes per side between the corners, and the corners.
    assert_eq!(count.len(), 4 * 3 + 4);
}

#[test]
fn a_film_slides_freely_down_a_clamped_wall_with_the_node_rows() {
    // A 0.1 m film of water against the face of a clamped elastic wall, gravity tilted
    // towards the wall (the validation case free_slip_wall at Δx = 1/32 m): with free slip it
    // moves as if the wall were not there, v = g_t t along the face.
    let n = 32;
    let dx = 1.0 / n as Real;
    let face = 0.4;
    let mut ps = Particles::new(columns());
    let still = Vector::<2>::zeros();
    lattice(
        &mut ps,
        ([face, 0.5], [face + 0.1, 0.8]),
        dx,
        (0, RHO_F),
        still,
        |_| true,
    );
    lattice(
        &mut ps,
        ([0.2, 0.1], [face, 0.9]),
        dx,
        (1, 1000.0),
        still,
        |_| true,
    );
    let tlmpm = mpm_tlmpm::TlmpmParams {
        fixed: vec![mpm_tlmpm::FixedRegion::clamp(
            Vector::<2>::zeros(),
            Vector::<2>::new(face - 3.0 * dx, 1.0),
        )],
        ..mpm_tlmpm::TlmpmParams::default()
    };
    let (g_n, g_t) = (2.0, 9.6);
    let mut p = params::<2>(5e-3, true);
    p.gravity = Vector::<2>::new(-g_n, -g_t);
    p.position_correction = false;
    let mut s = DiqCoupled::new(
        GridSpec::new(Vector::<2>::from_element(-dx), dx, [n + 3, n + 3]),
        p,
        SolidParams {
            interface: InterfaceQuadrature::FluidNodes,
            tlmpm,
            ..SolidParams::default()
        },
        materials(1000.0, 1e6),
        walls(false),
        ps,
    )
    .unwrap();
    while s.time() < 0.15 {
        s.step().unwrap();
    }
    let p = s.particles();
    let film = s.fluid_indices();
    let m: Real = film.iter().map(|&f| p.mass[f]).sum();
    let v = -film.iter().map(|&f| p.mass[f] * p.v[f][1]).sum::<Real>() / m;
    let ratio = v / (g_t * s.time());
    assert!((ratio - 1.0).abs() < 0.01, "film at {ratio} of free slide");
    // Still on the wall: pressed against it, not flying off.
    let gap = film
        .iter()
        .map(|&f| p.x[f][0])
        .fold(Real::INFINITY, Real::min)
        - face;
    assert!(gap < 0.5 * dx, "film {gap} m off the wall");
}

#[test]
fn a_block_released_on_viscous_water_settles_at_its_draft_with_the_node_rows() {
    // The scene of the validation case floating_block_diq at Δx = 1/32 m, ρs/ρf = 0.5: a
    // 0.2 × 0.1 m block released with its bottom on 0.2 m of 50 Pa·s water in the unit tank.
    // Archimedes: draft (ρs/ρf) h = 0.05 m.
    let n = 32;
    let dx = 1.0 / n as Real;
    let (depth, (x0, x1), height) = (0.2, (0.4, 0.6), 0.1);
    let mut ps = Particles::new(columns());
    let still = Vector::<2>::zeros();
    lattice(
        &mut ps,
        ([0.0, 0.0], [1.0, depth]),
        dx,
        (0, RHO_F),
        still,
        |_| true,
    );
    lattice(
        &mut ps,
        ([x0, depth], [x1, depth + height]),
        dx,
        (1, 500.0),
        still,
        |_| true,
    );
    let mut mats = materials(500.0, 5e4);
    if let Material::Fluid(f) = &mut mats[0] {
        f.viscosity = 50.0;
    }
    let mut p = params::<2>(3e-3, true);
    p.position_correction = false;
    let mut s = DiqCoupled::new(
        GridSpec::new(Vector::<2>::from_element(-dx), dx, [n + 3, n + 3]),
        p,
        SolidParams {
            interface: InterfaceQuadrature::FluidNodes,
            tlmpm: mpm_tlmpm::TlmpmParams {
                contact: tank_walls(),
                ..mpm_tlmpm::TlmpmParams::default()
            },
            ..SolidParams::default()
        },
        mats,
        walls(true),
        ps,
    )
    .unwrap();
    let solid = s.solid_indices().to_vec();
    let centre = |s: &DiqCoupled<2>| {
        let p = s.particles();
        solid.iter().map(|&q| p.x[q][0]).sum::<Real>() / solid.len() as Real
    };
    let start = centre(&s);
    let draft = |s: &DiqCoupled<2>| {
        let p = s.particles();
        // The free surface beside the left wall and the block's bottom face, each a quarter
        // cell beyond its outermost particle row (2 particles per cell and axis).
        let surface = s
            .fluid_indices()
            .iter()
            .filter(|&&q| p.x[q][0] < 0.2)
            .map(|&q| p.x[q][1])
            .fold(Real::NEG_INFINITY, Real::max)
            + 0.25 * dx;
        let bottom = lowest(s) - 0.25 * dx;
        surface - bottom
    };
    let (mut sum, mut count, mut swing) = (0.0, 0, (Real::INFINITY, Real::NEG_INFINITY));
    while s.time() < 2.0 {
        s.step().unwrap();
        if s.time() > 1.5 {
            let d = draft(&s);
            sum += d;
            count += 1;
            swing = (swing.0.min(d), swing.1.max(d));
        }
    }
    let mean = sum / count as Real;
    assert!(
        (mean - 0.05).abs() < 0.5 * dx,
        "draft {mean} m against 0.05 m (Δx = {dx} m)"
    );
    assert!(
        swing.1 - swing.0 < 0.25 * dx,
        "heave {} m",
        swing.1 - swing.0
    );
    let drift = (centre(&s) - start).abs();
    assert!(drift < 0.5 * dx, "drift {drift} m");
}
