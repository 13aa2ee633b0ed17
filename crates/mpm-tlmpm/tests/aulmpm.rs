//! A-ULMPM reference updates (diq-mpm §5.4): identity with TLMPM when the trigger never
//! fires, and collapsing sand and snow columns that need the updates.

mod common;

use common::{block, grid_around, lattice, neo_hookean, particles_of};
use mpm_core::boundary::ColliderShape;
use mpm_core::material::{DruckerPrager, ElasticModel, Lame, Plasticity, Snow, SolidMaterial};
use mpm_core::Solver as _;
use mpm_core::{Columns, Material, Particles, Real, StepControl, TimeStepPolicy, Vector};
use mpm_tlmpm::{
    ContactParams, ContactRadius, ExplicitTlmpm, FixedRegion, ImplicitParams, ImplicitTlmpm,
    Obstacle, ReferenceConfig, ReferenceUpdate, TlmpmParams,
};

/// Either solver, stepped the same way.
enum Solver {
    Explicit(Box<ExplicitTlmpm<2>>),
    Implicit(Box<ImplicitTlmpm<2>>),
}

impl Solver {
    fn new(
        implicit: bool,
        (grid, params): (mpm_core::GridSpec<2>, TlmpmParams<2>),
        materials: Vec<Material>,
        particles: Particles<2>,
    ) -> Self {
        if implicit {
            Self::Implicit(Box::new(
                ImplicitTlmpm::new(
                    grid,
                    params,
                    ImplicitParams::default(),
                    materials,
                    particles,
                )
                .unwrap(),
            ))
        } else {
            Self::Explicit(Box::new(
                ExplicitTlmpm::new(grid, params, materials, particles).unwrap(),
            ))
        }
    }

    fn step(&mut self) {
        match self {
            Self::Explicit(s) => {
                s.step().unwrap();
            }
            Self::Implicit(s) => {
                s.step().unwrap();
            }
        }
    }

    fn particles(&self) -> &Particles<2> {
        match self {
            Self::Explicit(s) => s.particles(),
            Self::Implicit(s) => s.particles(),
        }
    }

    fn reference(&self) -> &ReferenceConfig<2> {
        match self {
            Self::Explicit(s) => s.reference(),
            Self::Implicit(s) => s.reference(),
        }
    }

    fn updates(&self) -> u64 {
        match self {
            Self::Explicit(s) => s.reference_updates(),
            Self::Implicit(s) => s.reference_updates(),
        }
    }

    fn time(&self) -> Real {
        match self {
            Self::Explicit(s) => s.time(),
            Self::Implicit(s) => s.time(),
        }
    }
}

#[test]
fn a_trigger_that_never_fires_is_bitwise_tlmpm() {
    let bounds = (Vector::<2>::new(0.3, 0.3), Vector::<2>::new(0.7, 0.7));
    let c = Vector::<2>::from_element(0.5);
    let particles = block(&grid_around(bounds, 0.1, 3), bounds, 0.05, 1000.0, |x| {
        let d = x - c;
        Vector::<2>::new(0.5 * d.x - 2.0 * d.y, 0.5 * d.y + 2.0 * d.x)
    });
    let base = TlmpmParams {
        step: StepControl {
            gravity: Vector::<2>::new(0.0, -9.81),
            time_step: TimeStepPolicy::Fixed { dt: 2e-3 },
            ..StepControl::default()
        },
        fixed: vec![FixedRegion::clamp(
            Vector::<2>::zeros(),
            Vector::<2>::from_element(0.3),
        )],
        ..TlmpmParams::default()
    };
    let never = TlmpmParams {
        reference_update: Some(ReferenceUpdate {
            epsilon: Real::INFINITY,
            eta: 0.0,
        }),
        ..base.clone()
    };
    for implicit in [false, true] {
        let run = |params: &TlmpmParams<2>| {
            let mut s = Solver::new(
                implicit,
                (grid_around(bounds, 0.1, 3), params.clone()),
                vec![neo_hookean(1e5, 0.3, 1000.0)],
                particles.clone(),
            );
            for _ in 0..10 {
                s.step();
            }
            assert_eq!(s.updates(), 0);
            s.particles().clone()
        };
        assert_eq!(run(&base), run(&never), "implicit: {implicit}");
    }
}

/// Friction angle hardening of Klár et al. 2016 (degrees; h₂ dimensionless).
const SAND_H: [Real; 4] = [35.0, 9.0, 0.2, 10.0];

fn sand(lame: Lame) -> Material {
    Material::Solid(SolidMaterial {
        density: 1500.0,
        elastic: ElasticModel::Hencky(lame),
        plasticity: Plasticity::DruckerPrager(DruckerPrager {
            h: SAND_H,
            cohesion: 0.0,
            volume_correction: false,
        }),
    })
}

fn snow(lame: Lame) -> Material {
    Material::Solid(SolidMaterial {
        density: 400.0,
        elastic: ElasticModel::FixedCorotated(lame),
        plasticity: Plasticity::Snow(Snow {
            theta_c: 2.5e-2,
            theta_s: 7.5e-3,
            hardening: 10.0,
        }),
    })
}

/// A column 0.1 m wide and 0.2 m tall (Δx = 0.02 m, 2 × 2 particles per cell) standing on a
/// frictionless wall (the half-space y ≤ 0) under gravity collapses with A-ULMPM
/// (ε = η = 0.01). Checks after every step: node masses sum to the particle mass (mass
/// conservation through every reference update) and, for sand, every particle's elastic state
/// is inside the Drucker–Prager cone. At the end: reference updates happened. Returns the final
/// width (m) and the smallest snow plastic volume ratio `J_P`.
fn collapse(material: Material, implicit: bool, end: Real) -> (Real, Real) {
    let (dx, radius) = (0.02, 0.01);
    let bounds = (
        Vector::<2>::new(0.3, radius),
        Vector::<2>::new(0.4, 0.2 + radius),
    );
    // The grid covers wherever the particles may go: the reference moves with them.
    let domain = (Vector::<2>::new(0.0, -0.05), Vector::<2>::new(0.7, 0.3));
    let grid = grid_around(domain, dx, 3);
    let plastic = Columns {
        plastic: true,
        ..Columns::default()
    };
    let column = lattice(bounds, dx / 2.0, (material.density(), 0));
    let particles = particles_of(&grid, plastic, &[column]);
    let mass: Real = particles.mass.iter().sum();
    let floor = Obstacle::Collider(ColliderShape::HalfSpace {
        point: Vector::<2>::zeros(),
        normal: Vector::<2>::new(0.0, 1.0),
    });
    let params = TlmpmParams {
        step: StepControl {
            gravity: Vector::<2>::new(0.0, -9.81),
            time_step: TimeStepPolicy::Fixed {
                dt: if implicit { 2e-3 } else { 4e-4 },
            },
            ..StepControl::default()
        },
        contact: Some(ContactParams {
            radius: ContactRadius::Fixed(radius),
            obstacles: vec![floor],
        }),
        reference_update: Some(ReferenceUpdate {
            epsilon: 0.01,
            eta: 0.01,
        }),
        ..TlmpmParams::default()
    };
    let dp = match &material {
        Material::Solid(SolidMaterial {
            plasticity: Plasticity::DruckerPrager(dp),
            elastic,
            ..
        }) => Some((*dp, elastic.lame())),
        _ => None,
    };
    let name = if dp.is_some() { "sand" } else { "snow" };
    let mut s = Solver::new(implicit, (grid, params), vec![material], particles);
    let (mut worst_yield, mut worst_mass) = (Real::NEG_INFINITY, 0.0 as Real);
    let mut steps = 0;
    while s.time() < end - 1e-9 {
        s.step();
        steps += 1;
        let node_mass: Real = s.reference().node_masses().iter().sum();
        worst_mass = worst_mass.max((node_mass - mass).abs() / mass);
        let p = s.particles();
        if let Some((dp, lame)) = dp {
            let (f, st) = (p.def_grad.as_ref().unwrap(), p.plastic.as_ref().unwrap());
            for (fe, state) in f.iter().zip(st) {
                worst_yield = worst_yield.max(dp.yield_function(fe, state.q, lame));
            }
        }
    }
    let p = s.particles();
    let (lo, hi) =
        p.x.iter()
            .fold((Real::INFINITY, Real::NEG_INFINITY), |(a, b), x| {
                (a.min(x.x), b.max(x.x))
            });
    let top = p.x.iter().map(|x| x.y).fold(Real::NEG_INFINITY, Real::max);
    let bottom = p.x.iter().map(|x| x.y).fold(Real::INFINITY, Real::min);
    println!(
        "{name} column ({}): {steps} steps, {} reference updates, particle span in x 0.09 → \
         {:.3} m, top 0.205 → {:.3} m, lowest particle {bottom:.4} m, node-mass error {worst_mass:.1e}, \
         largest yield function {worst_yield:.2e}",
        if implicit { "implicit" } else { "explicit" },
        s.updates(),
        hi - lo,
        top,
    );
    assert!(s.updates() > 0, "reference updates happen");
    assert!(worst_mass < 1e-12, "mass conserved: {worst_mass:e}");
    assert!(
        worst_yield <= 1e-9,
        "inside the yield surface: {worst_yield:e}"
    );
    assert!(bottom > -radius, "stays on the wall");
    let jp = p
        .plastic
        .as_ref()
        .unwrap()
        .iter()
        .map(|s| s.jp)
        .fold(1.0, Real::min);
    (hi - lo, jp)
}

#[test]
fn sand_column_collapses_with_reference_updates_explicit() {
    let (width, _) = collapse(sand(Lame::from_young_poisson(1e5, 0.3)), false, 0.3);
    assert!(width > 0.15, "the column spreads: {width}");
}

#[test]
fn sand_column_collapses_with_reference_updates_implicit() {
    let (width, _) = collapse(sand(Lame::from_young_poisson(1e5, 0.3)), true, 0.3);
    assert!(width > 0.15, "the column spreads: {width}");
}

#[test]
fn snow_column_collapses_with_reference_updates() {
    for implicit in [false, true] {
        let (_, jp) = collapse(snow(Lame::from_young_poisson(1e4, 0.2)), implicit, 0.3);
        println!("smallest J_P {jp:.4}");
        assert!(jp < 0.99, "the snow compacts plastically: J_P = {jp}");
    }
}
