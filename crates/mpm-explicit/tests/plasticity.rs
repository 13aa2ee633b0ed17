//! Plastic bodies inside the explicit solver keep their plastic invariants step after step.

mod common;

use common::{fill_box, particles_for};
use mpm_core::boundary::{Boundaries, Contact, ContactKind, DomainWalls};
use mpm_core::material::{DruckerPrager, ElasticModel, Lame, Plasticity, Snow, SolidMaterial};
use mpm_core::Solver as _;
use mpm_core::{Dim, DimOps, GridSpec, Material, Matrix, Real, StepControl, Vector};
use mpm_explicit::{ExplicitParams, ExplicitSolver};

fn floor() -> Boundaries<2> {
    Boundaries {
        walls: Some(DomainWalls {
            contact: Contact {
                kind: ContactKind::Sticky,
                friction: 0.0,
            },
            thickness: 3,
            treatment: Default::default(),
        }),
        colliders: vec![],
    }
}

fn drop_block(material: Material, v0: Vector<2>) -> ExplicitSolver<2> {
    let spec = GridSpec::<2>::new(Vector::<2>::zeros(), 1.0 / 64.0, [65, 65]);
    let rho = material.density();
    let materials = vec![material];
    let mut particles = particles_for::<2>(&materials);
    fill_box(
        &mut particles,
        &spec,
        (Vector::<2>::new(0.3, 0.06), Vector::<2>::new(0.5, 0.4)),
        2,
        (0, rho),
        move |_| (v0, Matrix::<2>::zeros()),
    );
    let params = ExplicitParams {
        step: StepControl {
            gravity: Vector::<2>::new(0.0, -9.81),
            ..StepControl::default()
        },
        ..ExplicitParams::default()
    };
    ExplicitSolver::new(spec, params, materials, floor(), particles).unwrap()
}

/// Snow thrown at the floor: every particle's elastic singular values stay in
/// [1 − θ_c, 1 + θ_s], and some particles did yield (J_P ≠ 1), so the bound is exercised.
#[test]
fn snow_singular_values_stay_in_bounds() {
    let snow = Snow {
        theta_c: 2.5e-2,
        theta_s: 7.5e-3,
        hardening: 10.0,
    };
    let material = Material::Solid(SolidMaterial {
        density: 400.0,
        elastic: ElasticModel::FixedCorotated(Lame::from_young_poisson(1.4e5, 0.2)),
        plasticity: Plasticity::Snow(snow),
    });
    let mut s = drop_block(material, Vector::<2>::new(1.0, -3.0));
    for _ in 0..400 {
        s.step().unwrap();
    }
    let (f, states) = (
        s.particles().def_grad.as_ref().unwrap(),
        s.particles().plastic.as_ref().unwrap(),
    );
    let tol = 1e-12;
    for fe in f {
        let sigma = Dim::<2>::svd(fe).sigma;
        for k in 0..2 {
            assert!(sigma[k] >= 1.0 - snow.theta_c - tol && sigma[k] <= 1.0 + snow.theta_s + tol);
        }
    }
    let yielded = states.iter().filter(|s| (s.jp - 1.0).abs() > 1e-3).count();
    assert!(
        yielded > states.len() / 10,
        "only {yielded} particles yielded"
    );
}

/// A sand column collapses under gravity: every particle stays inside its Drucker–Prager cone
/// and the column spreads (it is not elastic). The cone of a step is the one of the hardening
/// state at the start of that step (Klár et al. 2016 update q after the projection), so the last
/// step's F_E is checked against the states from before it.
#[test]
fn sand_stays_inside_its_yield_cone() {
    let dp = DruckerPrager {
        h: [35.0, 9.0, 0.2, 10.0],
        cohesion: 0.0,
        volume_correction: true,
    };
    let lame = Lame::from_young_poisson(3.5e5, 0.3);
    let material = Material::Solid(SolidMaterial {
        density: 1600.0,
        elastic: ElasticModel::Hencky(lame),
        plasticity: Plasticity::DruckerPrager(dp),
    });
    let mut s = drop_block(material, Vector::<2>::zeros());
    let width0 = spread(&s);
    s.run_until(0.3).unwrap();
    let states = s.particles().plastic.clone().unwrap();
    s.step().unwrap();
    let f = s.particles().def_grad.as_ref().unwrap();
    let worst = f
        .iter()
        .zip(&states)
        .map(|(fe, st)| dp.yield_function(fe, st.q, lame))
        .fold(Real::NEG_INFINITY, Real::max);
    assert!(worst <= 1e-10, "yield function {worst:e} > 0");
    let yielded = states.iter().filter(|st| st.q > 0.0).count();
    assert!(
        yielded > states.len() / 10,
        "only {yielded} particles yielded"
    );
    assert!(
        spread(&s) > 1.3 * width0,
        "column did not collapse: {} -> {}",
        width0,
        spread(&s)
    );
}

fn spread<const D: usize>(s: &ExplicitSolver<D>) -> Real
where
    Dim<D>: DimOps<D>,
{
    let xs = s.particles().x.iter().map(|x| x[0]);
    xs.clone().fold(Real::NEG_INFINITY, Real::max) - xs.fold(Real::INFINITY, Real::min)
}
