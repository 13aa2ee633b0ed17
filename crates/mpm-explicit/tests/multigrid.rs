//! Physics checks of multi-grid MLS-MPM (multigrid paper §4): phases, couplings, porous
//! interaction, mixing and dissolution.

mod common;

use common::{fill_box, jelly, water, with_threads};
use mpm_core::boundary::{Boundaries, Collider, ColliderShape, Contact, ContactKind};
use mpm_core::material::{FluidMaterial, Interaction, Parameter, Scaling, Tait};
use mpm_core::{
    Columns, Dim, DimOps, GridSpec, Kernel, Material, Matrix, Particles, Real, Solver, StepControl,
    TimeStepPolicy, Vector,
};
use mpm_explicit::{
    Activation, BuoyancyPenalty, ContactCoupling, Coupling, CouplingKind, DiffusionScheme,
    Dissolution, Drag, EffectiveFraction, ExplicitParams, ExplicitSolver, Friction, Mixing, Phases,
    Porous, PressureBuoyancy,
};

fn spec<const D: usize>(n: usize) -> GridSpec<D> {
    GridSpec::new(Vector::<D>::zeros(), 1.0 / (n - 1) as Real, [n; D])
}

fn columns(materials: &[Material], phase: bool) -> Columns {
    Columns {
        phase,
        ..Columns::for_materials(materials)
    }
}

fn coupling(kind: CouplingKind) -> Coupling {
    Coupling {
        phases: [0, 1],
        kind,
        buoyancy: None,
        pressure_buoyancy: PressureBuoyancy::Off,
    }
}

fn walls() -> Boundaries<2> {
    Boundaries::slip_walls(2)
}

/// A jelly block (material 0) dropped into a water pool (material 1) in a walled box; with
/// `phase`, the water is phase 1.
fn jelly_and_water(phase: bool, gravity: Real) -> (GridSpec<2>, Vec<Material>, Particles<2>) {
    let spec = spec::<2>(41);
    let materials = vec![jelly(2e4, 0.3, 400.0), water(2e4, 0.0)];
    let mut particles = Particles::new(columns(&materials, phase));
    let still = |_: &Vector<2>| (Vector::<2>::new(0.3, -0.5), Default::default());
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.35, 0.35), Vector::<2>::new(0.6, 0.6)),
        2,
        (0, 400.0),
        still,
    );
    let n_solid = particles.len();
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.1, 0.1), Vector::<2>::new(0.9, 0.35)),
        2,
        (1, 1000.0),
        |_| Default::default(),
    );
    if let Some(k) = &mut particles.phase {
        k[n_solid..].fill(1);
    }
    let _ = gravity;
    (spec, materials, particles)
}

fn solver(
    (spec, materials, particles): (GridSpec<2>, Vec<Material>, Particles<2>),
    phases: Phases,
    boundaries: Boundaries<2>,
    gravity: Real,
) -> ExplicitSolver<2> {
    let params = ExplicitParams {
        step: StepControl {
            gravity: Vector::<2>::new(0.0, gravity),
            time_step: TimeStepPolicy::Fixed { dt: 2e-4 },
            ..StepControl::default()
        },
        phases,
        ..ExplicitParams::default()
    };
    ExplicitSolver::new(spec, params, materials, boundaries, particles).unwrap()
}

fn max_position_difference(a: &Particles<2>, b: &Particles<2>) -> Real {
    a.x.iter()
        .zip(&b.x)
        .map(|(x, y)| (x - y).norm())
        .fold(0.0, Real::max)
}

#[test]
fn one_phase_with_a_phase_column_is_bitwise_the_single_grid_run() {
    let mut plain = solver(
        jelly_and_water(false, -9.81),
        Phases::default(),
        walls(),
        -9.81,
    );
    let mut tagged = jelly_and_water(true, -9.81);
    tagged.2.phase.as_mut().unwrap().fill(0);
    let mut tagged = solver(tagged, Phases::default(), walls(), -9.81);
    for _ in 0..40 {
        plain.step().unwrap();
        tagged.step().unwrap();
    }
    assert!(!Solver::plan(&plain).contains(mpm_explicit::stages::COUPLING));
    for p in 0..plain.particles().len() {
        assert_eq!(plain.particles().x[p], tagged.particles().x[p]);
        assert_eq!(plain.particles().v[p], tagged.particles().v[p]);
    }
}

#[test]
fn full_and_maximal_drag_reproduce_the_single_grid_run() {
    let steps = 100;
    let mut single = solver(
        jelly_and_water(false, -9.81),
        Phases::default(),
        walls(),
        -9.81,
    );
    for _ in 0..steps {
        single.step().unwrap();
    }
    for kind in [
        CouplingKind::Full,
        CouplingKind::Drag(Drag::Coefficient(1e30)),
        CouplingKind::Contact(ContactCoupling {
            normal_share: 1.0,
            friction: Friction::Proportional(1.0),
            activation: Activation::Always,
        }),
    ] {
        let phases = Phases {
            count: 2,
            couplings: vec![coupling(kind)],
        };
        let mut two = solver(jelly_and_water(true, -9.81), phases, walls(), -9.81);
        for _ in 0..steps {
            two.step().unwrap();
        }
        let d = max_position_difference(single.particles(), two.particles());
        // Round-off only: positions are O(1) m and the runs differ in summation order.
        assert!(d < 1e-12, "{kind:?}: positions differ by {d:e} m");
        let plan = Solver::plan(&two);
        assert!(plan.stages.iter().any(
            |s| s.stage == mpm_explicit::stages::COUPLING && s.detail.contains("coupling 0-1")
        ));
    }
}

#[test]
fn couplings_conserve_total_momentum_without_gravity() {
    let contact = CouplingKind::Contact(ContactCoupling {
        normal_share: 1.0,
        friction: Friction::Coulomb(0.3),
        activation: Activation::OnApproach,
    });
    for kind in [
        contact,
        CouplingKind::Drag(Drag::Coefficient(1e-2)),
        CouplingKind::Full,
    ] {
        let mut c = coupling(kind);
        c.buoyancy = Some(BuoyancyPenalty { strength: 1.0 });
        let phases = Phases {
            count: 2,
            couplings: vec![c],
        };
        let mut s = solver(
            jelly_and_water(true, 0.0),
            phases,
            Boundaries::default(),
            0.0,
        );
        let p0 = s.diagnostics().momentum;
        let scale: Real = (0..s.particles().len())
            .map(|p| s.particles().mass[p] * s.particles().v[p].norm())
            .sum();
        for _ in 0..150 {
            s.step().unwrap();
        }
        let drift = (s.diagnostics().momentum - p0).norm() / scale;
        assert!(drift < 1e-13, "{kind:?}: relative momentum drift {drift:e}");
    }
}

/// A water column sliding down along a fixed vertical jelly wall in zero gravity with a
/// tangential velocity: returns the mean tangential (y) velocity of the water after `steps`.
fn slide(phases: Phases, phase: bool) -> (Real, Real) {
    let spec = spec::<2>(41);
    let materials = vec![jelly(1e5, 0.3, 1000.0), water(2e4, 0.0)];
    let mut particles = Particles::new(columns(&materials, phase));
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.3, 0.2), Vector::<2>::new(0.5, 0.8)),
        2,
        (0, 1000.0),
        |_| Default::default(),
    );
    let n_solid = particles.len();
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.5, 0.3), Vector::<2>::new(0.6, 0.7)),
        2,
        (1, 1000.0),
        // Pressed gently onto the wall while sliding down it.
        |_| (Vector::<2>::new(-0.05, -1.0), Default::default()),
    );
    if let Some(k) = &mut particles.phase {
        k[n_solid..].fill(1);
    }
    let mut s = solver(
        (spec, materials, particles),
        phases,
        Boundaries::default(),
        0.0,
    );
    let mean_vy = |s: &ExplicitSolver<2>| {
        let water = n_solid..s.particles().len();
        let n = water.len() as Real;
        water.map(|p| s.particles().v[p].y).sum::<Real>() / n
    };
    let before = mean_vy(&s);
    for _ in 0..250 {
        s.step().unwrap();
    }
    (before, mean_vy(&s))
}

#[test]
fn frictionless_contact_slides_where_the_single_grid_sticks() {
    let (v0, sticky) = slide(Phases::default(), false);
    let contact = Phases {
        count: 2,
        couplings: vec![coupling(CouplingKind::Contact(ContactCoupling {
            normal_share: 1.0,
            friction: Friction::Coulomb(0.0),
            activation: Activation::OnApproach,
        }))],
    };
    let (_, sliding) = slide(contact, true);
    // The single grid drags the whole water column with the heavy wall.
    assert!(
        sticky.abs() < 0.6 * v0.abs(),
        "single grid: {sticky} of {v0}"
    );
    // δ = 0: only the normal approach is stopped; the water keeps its tangential velocity up
    // to the tangential share of the discrete normals at the ends of the column (about 2%).
    assert!(
        (sliding - v0).abs() < 0.05 * v0.abs(),
        "contact: {sliding} of {v0}"
    );
}

fn mixing_box<const D: usize>(scheme: DiffusionScheme) -> ExplicitSolver<D>
where
    Dim<D>: DimOps<D>,
{
    mixing_box_with::<D>(scheme, None)
}

/// [`mixing_box`], with every particle at concentration `uniform` when given.
fn mixing_box_with<const D: usize>(
    scheme: DiffusionScheme,
    uniform: Option<Real>,
) -> ExplicitSolver<D>
where
    Dim<D>: DimOps<D>,
{
    let spec = spec::<D>(25);
    let fluid = FluidMaterial {
        density: 1000.0,
        eos: Tait {
            bulk_modulus: 1e4,
            gamma: 7.0,
        },
        viscosity: 0.0,
    };
    let thick = FluidMaterial {
        viscosity: 0.5,
        ..fluid
    };
    let materials = vec![Material::Fluid(fluid), Material::Fluid(thick)];
    let cols = Columns {
        concentration: true,
        ..Columns::for_materials(&materials)
    };
    let mut particles = Particles::new(cols);
    let (lo, hi) = (0.2, 0.8);
    fill_box(
        &mut particles,
        &spec,
        (Vector::<D>::from_element(lo), Vector::<D>::from_element(hi)),
        2,
        (0, 1000.0),
        |_| (Vector::<D>::zeros(), Matrix::<D>::zeros()),
    );
    for p in 0..particles.len() {
        if particles.x[p][0] > 0.5 {
            particles.material[p] = 1;
            particles.concentration.as_mut().unwrap()[p] = 1.0;
        }
        if let Some(a) = uniform {
            particles.concentration.as_mut().unwrap()[p] = a;
        }
    }
    let params = ExplicitParams {
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt: 1e-3 },
            ..StepControl::default()
        },
        mixing: Some(Mixing {
            fluids: [0, 1],
            diffusivity: 1e-3,
            scheme,
        }),
        ..ExplicitParams::default()
    };
    ExplicitSolver::new(spec, params, materials, Boundaries::default(), particles).unwrap()
}

fn diffusion_mixes_and_conserves<const D: usize>()
where
    Dim<D>: DimOps<D>,
{
    let mut s = mixing_box::<D>(DiffusionScheme::KernelGradient);
    let total = |s: &ExplicitSolver<D>| -> Real {
        let c = s.particles().concentration.as_ref().unwrap();
        (0..c.len()).map(|p| s.particles().volume0[p] * c[p]).sum()
    };
    let spread = |s: &ExplicitSolver<D>| -> Real {
        let c = s.particles().concentration.as_ref().unwrap();
        c.iter().fold(0.0, |m: Real, &a| m.max((a - 0.5).abs()))
    };
    let (q0, m0) = (total(&s), s.diagnostics().mass);
    for _ in 0..200 {
        s.step().unwrap();
    }
    let q = total(&s);
    // Round-off only: about 1e-15 per step.
    assert!(
        ((q - q0) / q0).abs() < 1e-14 * 200.0,
        "Σ V α drifted by {:e}",
        (q - q0) / q0
    );
    // Equal densities: mass unchanged.
    assert!(((s.diagnostics().mass - m0) / m0).abs() < 1e-13);
    assert!(
        spread(&s) < 0.5,
        "the interface smoothed: max |α − 1/2| = {}",
        spread(&s)
    );
    assert!(Solver::plan(&s).contains(mpm_explicit::stages::DIFFUSION));
}

#[test]
fn diffusion_mixes_and_conserves_concentration() {
    diffusion_mixes_and_conserves::<2>();
    diffusion_mixes_and_conserves::<3>();
}

#[test]
fn porous_interaction_wets_the_solid_and_scales_its_parameters() {
    // Sand-like jelly (phase 0) under water (phase 1), overlapping, drag coupled.
    let spec = spec::<2>(33);
    let materials = vec![jelly(1e5, 0.3, 1500.0), water(2e4, 0.0)];
    let cols = Columns {
        phase: true,
        volume_fraction: true,
        ..Columns::for_materials(&materials)
    };
    let mut particles = Particles::new(cols);
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.2, 0.1), Vector::<2>::new(0.5, 0.4)),
        2,
        (0, 1500.0),
        |_| Default::default(),
    );
    let n_solid = particles.len();
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.2, 0.3), Vector::<2>::new(0.5, 0.6)),
        2,
        (1, 1000.0),
        |_| Default::default(),
    );
    particles.phase.as_mut().unwrap()[n_solid..].fill(1);
    let params = ExplicitParams {
        step: StepControl {
            gravity: Vector::<2>::new(0.0, -9.81),
            time_step: TimeStepPolicy::Fixed { dt: 2e-4 },
            ..StepControl::default()
        },
        phases: Phases {
            count: 2,
            couplings: vec![coupling(CouplingKind::Drag(Drag::Coefficient(1e30)))],
        },
        porous: Some(Porous {
            update: EffectiveFraction::Max,
            interactions: vec![Interaction {
                material: 0,
                parameter: Parameter::YoungsModulus,
                scaling: Scaling {
                    offset: 1.0,
                    slope: -0.9,
                    exponent: 1.0,
                },
            }],
        }),
        ..ExplicitParams::default()
    };
    let mut s = ExplicitSolver::new(spec, params, materials, walls(), particles).unwrap();
    for _ in 0..50 {
        s.step().unwrap();
    }
    let phi = s.particles().volume_fraction.as_ref().unwrap();
    let solid = &phi[..n_solid];
    // The overlap band is wet (φ = 1 inside it), the bottom of the sand is not yet.
    let top = (0..n_solid)
        .filter(|&p| s.particles().x[p].y > 0.33)
        .map(|p| phi[p])
        .fold(1.0, Real::min);
    let bottom = (0..n_solid)
        .filter(|&p| s.particles().x[p].y < 0.15)
        .map(|p| phi[p])
        .fold(0.0, Real::max);
    assert!(top > 0.99, "overlap band φ_eff ≥ {top}");
    assert!(bottom < 0.01, "dry bottom φ_eff ≤ {bottom}");
    assert!(solid.iter().all(|&f| (0.0..=1.0).contains(&f)));
    // Eq. 21 never dries: φ_eff is monotone in time.
    let before = phi.to_vec();
    for _ in 0..20 {
        s.step().unwrap();
    }
    let after = s.particles().volume_fraction.as_ref().unwrap();
    assert!(before.iter().zip(after).all(|(b, a)| a >= b));
}

/// A jelly block (material 0, phase 0) dissolving into water (material 1, phase 1) as a viscous
/// solute fluid (material 2), coupled by `kind`, with diffusion; returns the solver and the
/// number of solid particles (the first ones).
fn dissolution_scene_with(kind: CouplingKind) -> (ExplicitSolver<2>, usize) {
    let spec = spec::<2>(33);
    let solvent = FluidMaterial {
        density: 1000.0,
        eos: Tait {
            bulk_modulus: 2e4,
            gamma: 7.0,
        },
        viscosity: 0.0,
    };
    let dissolved = FluidMaterial {
        viscosity: 0.1,
        ..solvent
    };
    let materials = vec![
        jelly(5e4, 0.3, 1000.0),
        Material::Fluid(solvent),
        Material::Fluid(dissolved),
    ];
    let cols = Columns {
        phase: true,
        concentration: true,
        ..Columns::for_materials(&materials)
    };
    let mut particles = Particles::new(cols);
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.4, 0.1), Vector::<2>::new(0.6, 0.3)),
        2,
        (0, 1000.0),
        |_| Default::default(),
    );
    let n_solid = particles.len();
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.1, 0.1), Vector::<2>::new(0.4, 0.3)),
        2,
        (1, 1000.0),
        |_| Default::default(),
    );
    particles.phase.as_mut().unwrap()[n_solid..].fill(1);
    let params = ExplicitParams {
        step: StepControl {
            gravity: Vector::<2>::new(0.0, -9.81),
            time_step: TimeStepPolicy::Fixed { dt: 2e-4 },
            ..StepControl::default()
        },
        phases: Phases {
            count: 2,
            couplings: vec![coupling(kind)],
        },
        mixing: Some(Mixing {
            fluids: [1, 2],
            diffusivity: 1e-3,
            scheme: DiffusionScheme::KernelGradient,
        }),
        dissolution: Some(Dissolution {
            solid: 0,
            into: 2,
            fluid_phase: 1,
            rate: 20.0,
        }),
        kernel: Kernel::Quadratic,
        ..ExplicitParams::default()
    };
    let s = ExplicitSolver::new(spec, params, materials, walls(), particles).unwrap();
    (s, n_solid)
}

/// [`dissolution_scene_with`] with frictional contact on approach (an impermeable solid).
fn dissolution_scene() -> (ExplicitSolver<2>, usize) {
    dissolution_scene_with(CouplingKind::Contact(ContactCoupling {
        normal_share: 1.0,
        friction: Friction::Coulomb(0.5),
        activation: Activation::OnApproach,
    }))
}

/// A porous solid (drag coupling lets the water in) dissolves faster than an impermeable one
/// (contact coupling keeps the water at its surface), as §4.5 says: after 0.2 s the water has
/// reached 85% of the porous block and 57% of the impermeable one.
#[test]
fn porous_solid_dissolves_faster() {
    // Fraction of the solid's particles that the water has reached.
    let progress = |(mut s, n_solid): (ExplicitSolver<2>, usize)| {
        for _ in 0..1000 {
            s.step().unwrap();
        }
        let c = s.particles().concentration.as_ref().unwrap();
        (0..n_solid).filter(|&p| c[p] > 0.0).count() as Real / n_solid as Real
    };
    let sealed = progress(dissolution_scene());
    let porous = progress(dissolution_scene_with(CouplingKind::Drag(
        Drag::Coefficient(1e-3),
    )));
    assert!(
        porous > 1.3 * sealed && sealed > 0.0,
        "wetted fraction: porous {porous:.4}, impermeable {sealed:.4}"
    );
}

#[test]
fn dissolution_turns_solid_into_fluid_and_keeps_mass() {
    let (mut s, n_solid) = dissolution_scene();
    let m0 = s.diagnostics().mass;
    for _ in 0..600 {
        s.step().unwrap();
    }
    let converted = (0..n_solid)
        .filter(|&p| s.particles().material[p] == 2)
        .count();
    assert!(converted > 0, "some solid dissolved");
    assert!(converted < n_solid, "not all at once");
    for p in (0..n_solid).filter(|&p| s.particles().material[p] == 2) {
        assert_eq!(s.particles().phase.as_ref().unwrap()[p], 1);
    }
    // The face touching the water dissolves first.
    let progress = s.particles().concentration.as_ref().unwrap();
    let left: Real = (0..n_solid)
        .filter(|&p| s.particles().material[p] == 0 && s.particles().x[p].x < 0.45)
        .map(|p| progress[p])
        .fold(0.0, Real::max);
    let right: Real = (0..n_solid)
        .filter(|&p| s.particles().material[p] == 0 && s.particles().x[p].x > 0.55)
        .map(|p| progress[p])
        .fold(0.0, Real::max);
    assert!(left > right, "wet face {left} vs dry face {right}");
    // Equal densities: the mass is unchanged by mixing and by the change of material.
    assert!(((s.diagnostics().mass - m0) / m0).abs() < 1e-12);
}

/// Viscous fluid (Eq. 12, symmetrised as `μ(∇v + ∇vᵀ)`, the same force for incompressible
/// flow): a free fluid slab of height H with the shear mode `v_x = A cos(π y/H)` (free surfaces,
/// so the shear stress vanishes there) decays as `exp(−ν (π/H)² t)`.
#[test]
fn viscous_shear_mode_decays_at_the_analytic_rate() {
    let spec = spec::<2>(65);
    let (h, mu, rho) = (0.25, 60.0, 1000.0);
    let materials = vec![water(1e4, mu)];
    let mut particles = Particles::new(Columns::for_materials(&materials));
    let (y0, amp) = (0.375, 0.05);
    let k = std::f64::consts::PI / h;
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.05, y0), Vector::<2>::new(0.95, y0 + h)),
        2,
        (0, rho),
        move |x| {
            let s = (k * (x.y - y0)).sin();
            let v = Vector::<2>::new(amp * (k * (x.y - y0)).cos(), 0.0);
            let c = Matrix::<2>::new(0.0, -amp * k * s, 0.0, 0.0);
            (v, c)
        },
    );
    let dt = 2e-4;
    let params = ExplicitParams {
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt },
            ..StepControl::default()
        },
        ..ExplicitParams::default()
    };
    let mut s =
        ExplicitSolver::new(spec, params, materials, Boundaries::default(), particles).unwrap();
    // Amplitude by projection onto the mode, over the middle third in x (away from the ends).
    let amplitude = |s: &ExplicitSolver<2>| {
        let (mut num, mut den) = (0.0, 0.0);
        for p in 0..s.particles().len() {
            let x = s.particles().x[p];
            if (0.35..0.65).contains(&x.x) {
                let m = (k * (x.y - y0)).cos();
                num += s.particles().v[p].x * m;
                den += m * m;
            }
        }
        num / den
    };
    let a0 = amplitude(&s);
    let steps = 500;
    for _ in 0..steps {
        s.step().unwrap();
    }
    let t = steps as Real * dt;
    let expected = (-(mu / rho) * k * k * t).exp();
    let measured = amplitude(&s) / a0;
    assert!(
        (measured / expected - 1.0).abs() < 0.05,
        "amplitude ratio {measured:.4} vs exp(−ν k² t) = {expected:.4}"
    );
}

/// A uniform concentration is a steady state of both diffusion schemes (the reason the paper
/// normalised Eq. 34; the MLS difference form is exact for constant α instead).
#[test]
fn uniform_concentration_stays_uniform() {
    for scheme in [
        DiffusionScheme::KernelGradient,
        DiffusionScheme::MlsDifference,
    ] {
        let mut s = mixing_box_with::<2>(scheme, Some(0.3));
        for _ in 0..50 {
            s.step().unwrap();
        }
        let c = s.particles().concentration.as_ref().unwrap();
        let worst = c.iter().fold(0.0, |m: Real, &a| m.max((a - 0.3).abs()));
        assert!(worst < 1e-13, "{scheme:?}: max |α − 0.3| = {worst:e}");
    }
}

/// Multi-grid runs (coupling, diffusion, dissolution) are bitwise identical for any thread count.
#[test]
fn multigrid_steps_are_bitwise_equal_for_any_thread_count() {
    let run = |threads: usize| {
        with_threads(threads, || {
            let (mut s, _) = dissolution_scene();
            for _ in 0..200 {
                s.step().unwrap();
            }
            s.particles().clone()
        })
    };
    let (a, b) = (run(1), run(4));
    let bits = |p: &Particles<2>| -> Vec<u64> {
        let mut v: Vec<u64> =
            p.x.iter()
                .flat_map(|x| x.iter().map(|c| c.to_bits()))
                .collect();
        v.extend(
            p.concentration
                .as_ref()
                .unwrap()
                .iter()
                .map(|c| c.to_bits()),
        );
        v.extend(p.mass.iter().map(|m| m.to_bits()));
        v
    };
    assert_eq!(a.material, b.material);
    assert!(bits(&a) == bits(&b), "1 and 4 threads differ");
}

/// The two-phase jelly-and-water scene with a contact coupling, buoyancy and a sphere collider
/// under the water, without domain walls, on a grid of `nodes` nodes per axis from the origin
/// with Δx = 1/40 m.
fn sparse_scene(nodes: usize) -> ExplicitSolver<2> {
    let (spec, materials, particles) = jelly_and_water(true, -9.81);
    let spec = GridSpec::new(spec.origin, spec.dx, [nodes; 2]);
    let mut c = coupling(CouplingKind::Contact(ContactCoupling {
        normal_share: 1.0,
        friction: Friction::Coulomb(0.3),
        activation: Activation::OnApproach,
    }));
    c.buoyancy = Some(BuoyancyPenalty { strength: 1.0 });
    let phases = Phases {
        count: 2,
        couplings: vec![c],
    };
    let boundaries = Boundaries {
        walls: None,
        colliders: vec![Collider {
            shape: ColliderShape::Sphere {
                center: Vector::<2>::new(0.5, 0.0),
                radius: 0.09,
            },
            contact: Contact {
                kind: ContactKind::Slip,
                friction: 0.0,
            },
            velocity: Vector::<2>::zeros(),
        }],
    };
    solver((spec, materials, particles), phases, boundaries, -9.81)
}

#[test]
fn a_larger_domain_stores_the_same_blocks_and_gives_the_same_bits() {
    // 2 m and 16 m wide domains (81 and 641 nodes per axis; the material lies in the first
    // metre): the dense grid of the large one would be 63 times larger.
    let mut small = sparse_scene(81);
    let mut large = sparse_scene(641);
    for _ in 0..60 {
        small.step().unwrap();
        large.step().unwrap();
    }
    let (a, b) = (small.particles(), large.particles());
    for p in 0..a.len() {
        assert_eq!(a.x[p], b.x[p], "particle {p}");
        assert_eq!(a.v[p], b.v[p], "particle {p}");
    }
    // The collider acted: the bottom water above the sphere (top at y = 0.09 m, one node
    // row of the water's stencils inside it) is slowed while the bottom water beside it, with
    // no wall below, falls freely (v = −g t).
    let free = -9.81 * small.time();
    let phase = a.phase.as_ref().unwrap();
    let mean_vy = |column: &dyn Fn(Real) -> bool| {
        let v: Vec<Real> = (0..a.len())
            .filter(|&p| phase[p] == 1 && a.x[p].y < 0.12 && column(a.x[p].x))
            .map(|p| a.v[p].y)
            .collect();
        assert!(!v.is_empty());
        v.iter().sum::<Real>() / v.len() as Real
    };
    let held = mean_vy(&|x| (x - 0.5).abs() < 0.02);
    let falling = mean_vy(&|x| x < 0.2);
    assert!(
        held > 0.9 * free,
        "above the sphere: {held} m/s, free fall {free} m/s"
    );
    assert!(
        falling < 0.98 * free,
        "beside it: {falling} m/s, free fall {free} m/s"
    );
    // Storage follows the material, not the domain: the same blocks, the same node count.
    let (ls, ll) = (small.grid_layout(), large.grid_layout());
    assert_eq!(ls.len(), ll.len());
    assert!(ll.len() * 100 < large.spec().num_nodes());
    let (gs, gl) = (small.phase_grid(1).unwrap(), large.phase_grid(1).unwrap());
    for i in 0..ls.len() {
        let k = ll.index(&ls.node(i)).unwrap();
        assert_eq!(gs.mass[i].to_bits(), gl.mass[k].to_bits());
        assert_eq!(gs.velocity[i], gl.velocity[k]);
    }
}
