//! Checkpoint and restore: a run split in two, the second half continued from the particles
//! and [`TlmpmState`] of the first, is bitwise identical to the straight run, also across
//! A-ULMPM reference updates of a plastic (snow) column.

mod common;

use common::{lattice, particles_of};
use mpm_core::boundary::ColliderShape;
use mpm_core::material::{ElasticModel, Lame, Plasticity, Snow, SolidMaterial};
use mpm_core::Solver as _;
use mpm_core::{Columns, GridSpec, Material, Particles, StepControl, TimeStepPolicy, Vector};
use mpm_tlmpm::{
    ContactParams, ContactRadius, ExplicitTlmpm, ImplicitParams, ImplicitTlmpm, Obstacle,
    ReferenceUpdate, TlmpmParams, TlmpmState, Transfer,
};

/// A snow column of 0.1 m × 0.2 m (Δx = 0.02 m) collapsing on a penalty floor with A-ULMPM.
fn setup(implicit: bool) -> (GridSpec<2>, TlmpmParams<2>, Vec<Material>, Particles<2>) {
    let (dx, radius) = (0.02, 0.01);
    let snow = Material::Solid(SolidMaterial {
        density: 400.0,
        elastic: ElasticModel::FixedCorotated(Lame::from_young_poisson(1e4, 0.2)),
        plasticity: Plasticity::Snow(Snow {
            theta_c: 2.5e-2,
            theta_s: 7.5e-3,
            hardening: 10.0,
        }),
    });
    let grid = GridSpec::covering(
        Vector::<2>::new(-0.06, -0.11),
        Vector::<2>::new(0.76, 0.36),
        dx,
    );
    let plastic = Columns {
        plastic: true,
        ..Columns::default()
    };
    let bounds = (
        Vector::<2>::new(0.3, radius),
        Vector::<2>::new(0.4, 0.2 + radius),
    );
    let particles = particles_of(&grid, plastic, &[lattice(bounds, dx / 2.0, (400.0, 0))]);
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
            obstacles: vec![Obstacle::Collider(ColliderShape::HalfSpace {
                point: Vector::<2>::zeros(),
                normal: Vector::<2>::new(0.0, 1.0),
            })],
        }),
        reference_update: Some(ReferenceUpdate {
            epsilon: 0.01,
            eta: 0.01,
        }),
        ..TlmpmParams::default()
    };
    (grid, params, vec![snow], particles)
}

/// The snapshot of a run: particles, state.
type Saved = (Particles<2>, TlmpmState<2>);

fn explicit_run(start: Option<Saved>, steps: usize) -> Saved {
    let (grid, params, materials, particles) = setup(false);
    let (particles, state) = match start {
        Some((p, s)) => (p, Some(s)),
        None => (particles, None),
    };
    let mut s = ExplicitTlmpm::new(grid, params, materials, particles).unwrap();
    if let Some(state) = state {
        s.restore(state).unwrap();
    }
    for _ in 0..steps {
        s.step().unwrap();
    }
    (s.particles().clone(), s.state())
}

fn implicit_run(start: Option<Saved>, steps: usize) -> Saved {
    let (grid, params, materials, particles) = setup(true);
    let (particles, state) = match start {
        Some((p, s)) => (p, Some(s)),
        None => (particles, None),
    };
    let mut s = ImplicitTlmpm::new(
        grid,
        params,
        ImplicitParams::default(),
        materials,
        particles,
    )
    .unwrap();
    if let Some(state) = state {
        s.restore(state).unwrap();
    }
    for _ in 0..steps {
        s.step().unwrap();
    }
    (s.particles().clone(), s.state())
}

fn check(run: fn(Option<Saved>, usize) -> Saved, half: usize, name: &str) {
    let straight = run(None, 2 * half);
    let first = run(None, half);
    let updates_at_split = first.1.reference_updates;
    let resumed = run(Some(first), half);
    println!(
        "{name}: {} reference updates before the split, {} in all; final time {} s",
        updates_at_split, straight.1.reference_updates, straight.1.time
    );
    assert!(updates_at_split > 0, "the split follows reference updates");
    assert!(straight.1.reference_updates > updates_at_split);
    assert_eq!(straight.1, resumed.1, "{name}: state");
    assert_eq!(straight.0, resumed.0, "{name}: particles");
}

#[test]
fn resumed_explicit_run_is_bitwise_identical() {
    check(explicit_run, 150, "explicit");
}

#[test]
fn resumed_implicit_run_is_bitwise_identical() {
    check(implicit_run, 40, "implicit");
}

/// An elastic block falling on the penalty floor of [`setup`] with persistent node velocities
/// (no A-ULMPM, so the node velocities persist across the split).
fn persistent_run(start: Option<Saved>, steps: usize, drop_nodes: bool) -> Saved {
    let (grid, params, _, mut particles) = setup(false);
    particles.plastic = None;
    let params = TlmpmParams {
        transfer: Transfer::Persistent,
        reference_update: None,
        ..params
    };
    let jelly = Material::Solid(SolidMaterial {
        density: 400.0,
        elastic: ElasticModel::FixedCorotated(Lame::from_young_poisson(1e4, 0.2)),
        plasticity: Plasticity::None,
    });
    let (particles, state) = match start {
        Some((p, s)) => (p, Some(s)),
        None => (particles, None),
    };
    let mut s = ExplicitTlmpm::new(grid, params, vec![jelly], particles).unwrap();
    if let Some(mut state) = state {
        if drop_nodes {
            state.node_velocities = None;
        }
        s.restore(state).unwrap();
    }
    for _ in 0..steps {
        s.step().unwrap();
    }
    (s.particles().clone(), s.state())
}

#[test]
fn resumed_persistent_run_is_bitwise_identical() {
    let straight = persistent_run(None, 300, false);
    let first = persistent_run(None, 150, false);
    let nodes = first.1.node_velocities.as_ref().map_or(0, Vec::len);
    assert!(nodes > 0, "the state holds the node velocities");
    let resumed = persistent_run(Some(first.clone()), 150, false);
    assert_eq!(straight.1, resumed.1, "state");
    assert_eq!(straight.0, resumed.0, "particles");
    // Without them the resumed run restarts from a P2G transfer and departs from the straight
    // one.
    let restarted = persistent_run(Some(first), 150, true);
    assert_ne!(straight.0.x, restarted.0.x);
}
