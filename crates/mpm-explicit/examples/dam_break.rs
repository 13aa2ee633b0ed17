//! A 2D dam break with weakly compressible water: a column of 0.4 m × 0.6 m collapses in a
//! 1 m × 1 m box. Prints progress and the conservation figures at the end.
//!
//! Run with `cargo run --release -p mpm-explicit --example dam_break`.

use mpm_core::boundary::{Boundaries, Contact, ContactKind, DomainWalls};
use mpm_core::material::{FluidMaterial, Tait};
use mpm_core::sampling::{sample, Sampling, Shape};
use mpm_core::Solver as _;
use mpm_core::{Columns, GridSpec, Material, Matrix, ParticleInit, Particles, Vector};
use mpm_explicit::{ExplicitParams, ExplicitSolver};
use std::time::Instant;

fn main() {
    let dx = 1.0 / 64.0;
    let spec = GridSpec::<2>::covering(Vector::<2>::zeros(), Vector::<2>::new(1.0, 1.0), dx);
    let water = Material::Fluid(FluidMaterial {
        density: 1000.0,
        eos: Tait {
            bulk_modulus: 2e5,
            gamma: 7.0,
        },
        viscosity: 1e-3,
    });
    let materials = vec![water];
    let column = Shape::Box {
        min: Vector::<2>::new(0.05, 0.05),
        max: Vector::<2>::new(0.45, 0.65),
    };
    let lattice = Sampling::Lattice {
        per_axis: 2,
        jitter: 0.0,
        seed: 0,
    };
    let (xs, vols) = sample(&column, &lattice, &spec.origin, dx);
    let mut particles = Particles::<2>::new(Columns::for_materials(&materials));
    for (x, v0) in xs.into_iter().zip(vols) {
        particles.push(ParticleInit {
            x,
            v: Vector::<2>::zeros(),
            mass: 1000.0 * v0,
            volume0: v0,
            material: 0,
            affine: Matrix::<2>::zeros(),
        });
    }
    let boundaries = Boundaries {
        walls: Some(DomainWalls {
            contact: Contact {
                kind: ContactKind::Separate,
                friction: 0.0,
            },
            thickness: 3,
            treatment: Default::default(),
        }),
        colliders: vec![],
    };
    let params = ExplicitParams {
        gravity: Vector::<2>::new(0.0, -9.81),
        ..ExplicitParams::default()
    };
    let mut solver = match ExplicitSolver::new(spec, params, materials, boundaries, particles) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    let start = solver.diagnostics();
    let n = solver.particles().len();
    println!(
        "dam break: {n} particles, dx = {dx} m, {} threads",
        rayon::current_num_threads()
    );
    let wall = Instant::now();
    let end_time = 1.0;
    let mut next_report = 0.0;
    while solver.time() < end_time {
        if let Err(e) = solver.step() {
            eprintln!("error: {e}");
            std::process::exit(3);
        }
        if solver.time() >= next_report {
            let d = solver.diagnostics();
            println!(
                "t = {:6.3} s  step {:6}  KE = {:9.3} J  front x = {:.3} m",
                solver.time(),
                solver.steps(),
                d.kinetic_energy,
                solver.particles().x.iter().map(|x| x.x).fold(0.0, f64::max)
            );
            next_report += 0.1;
        }
    }
    let d = solver.diagnostics();
    let secs = wall.elapsed().as_secs_f64();
    println!(
        "done: {} steps in {secs:.2} s ({:.2e} particle-steps/s)",
        solver.steps(),
        n as f64 * solver.steps() as f64 / secs
    );
    println!(
        "mass drift {:.2e} (relative), energy {:.1} J -> {:.1} J",
        (d.mass - start.mass).abs() / start.mass,
        start.total_energy(),
        d.total_energy()
    );
}
