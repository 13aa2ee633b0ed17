//! The contact stage (diq-mpm §3.2, Eq. 4) inside both solvers: colliding disks and a block
//! dropped on a wall.

mod common;

use common::{block, grid_around, lattice, momentum, neo_hookean, particles_of};
use mpm_core::boundary::ColliderShape;
use mpm_core::Solver as _;
use mpm_core::{Columns, Particles, Real, StepControl, TimeStepPolicy, Vector};
use mpm_tlmpm::{
    ContactParams, ContactRadius, ExplicitTlmpm, ImplicitParams, ImplicitTlmpm, NewtonParams,
    Obstacle, TlmpmParams,
};

/// Grid spacing of the contact scenes (m); the contact radius is `0.5 Δx` (§5.3).
const DX: Real = 0.05;
const RADIUS: Real = 0.5 * DX;

/// Either solver, stepped the same way.
enum Solver {
    Explicit(Box<ExplicitTlmpm<2>>),
    Implicit(Box<ImplicitTlmpm<2>>),
}

impl Solver {
    /// Builds the explicit solver with `dt` (s), or the implicit one with `5 dt` when
    /// `implicit`.
    fn new(implicit: bool, params: TlmpmParams<2>, particles: Particles<2>, dt: Real) -> Self {
        let lo = particles
            .x
            .iter()
            .fold(Vector::<2>::from_element(1e9), |a, x| a.inf(x));
        let hi = particles
            .x
            .iter()
            .fold(Vector::<2>::from_element(-1e9), |a, x| a.sup(x));
        let grid = grid_around((lo, hi), DX, 3);
        let materials = vec![neo_hookean(1e5, 0.3, 1000.0)];
        if implicit {
            let params = TlmpmParams {
                step: StepControl {
                    time_step: TimeStepPolicy::Fixed { dt: 5.0 * dt },
                    ..params.step
                },
                ..params
            };
            let newton = NewtonParams {
                rel_tol: 1e-12,
                ..NewtonParams::default()
            };
            let ip = ImplicitParams {
                newton,
                ..ImplicitParams::default()
            };
            Self::Implicit(Box::new(
                ImplicitTlmpm::new(grid, params, ip, materials, particles).unwrap(),
            ))
        } else {
            let params = TlmpmParams {
                step: StepControl {
                    time_step: TimeStepPolicy::Fixed { dt },
                    ..params.step
                },
                ..params
            };
            Self::Explicit(Box::new(
                ExplicitTlmpm::new(grid, params, materials, particles).unwrap(),
            ))
        }
    }

    /// One step; returns the number of contacts (pairs + obstacle contacts) it found.
    fn step(&mut self) -> usize {
        let c = match self {
            Self::Explicit(s) => {
                s.step().unwrap();
                s.last_contact()
            }
            Self::Implicit(s) => {
                s.step().unwrap();
                s.last_contact()
            }
        };
        let c = c.expect("contact stage runs");
        c.pairs + c.obstacle_contacts
    }

    fn particles(&self) -> &Particles<2> {
        match self {
            Self::Explicit(s) => s.particles(),
            Self::Implicit(s) => s.particles(),
        }
    }

    fn energy(&self) -> Real {
        let d = match self {
            Self::Explicit(s) => s.diagnostics(),
            Self::Implicit(s) => s.diagnostics(),
        };
        d.kinetic_energy + d.elastic_energy
    }

    fn name(&self) -> &'static str {
        match self {
            Self::Explicit(_) => "explicit",
            Self::Implicit(_) => "implicit",
        }
    }
}

/// Two Neo-Hookean disks of radius 0.2 m (E = 0.1 MPa, ρ = 1000 kg/m², 2 particles per cell
/// per axis), 0.1 m apart, approaching each other at `v0` each. Particles `0..n/2` are the left
/// disk.
fn two_disks(v0: Real) -> Particles<2> {
    let r = 0.2;
    let disks = [(0.5, v0), (1.0, -v0)].map(|(c, v)| {
        let c = Vector::<2>::new(c, 0.5);
        let bounds = (
            c - Vector::<2>::from_element(r),
            c + Vector::<2>::from_element(r),
        );
        lattice(bounds, DX / 2.0, (1000.0, 0))
            .keep(move |x| (x - c).norm() <= r)
            .velocity(Vector::<2>::new(v, 0.0))
    });
    let domain = (Vector::<2>::new(0.3, 0.3), Vector::<2>::new(1.2, 0.7));
    particles_of(&grid_around(domain, DX, 3), Columns::default(), &disks)
}

fn contact_params(obstacles: Vec<Obstacle<2>>) -> TlmpmParams<2> {
    TlmpmParams {
        contact: Some(ContactParams {
            radius: ContactRadius::Fixed(RADIUS),
            obstacles,
        }),
        ..TlmpmParams::default()
    }
}

/// Simulation time (s).
fn time(s: &Solver) -> Real {
    match s {
        Solver::Explicit(e) => e.time(),
        Solver::Implicit(i) => i.time(),
    }
}

/// Mean x-velocity (m/s) of particles `range`.
fn mean_vx(p: &Particles<2>, range: std::ops::Range<usize>) -> Real {
    let n = range.len() as Real;
    p.v[range].iter().map(|v| v.x).sum::<Real>() / n
}

fn colliding_disks(implicit: bool) {
    let v0 = 1.0;
    let particles = two_disks(v0);
    let n = particles.len();
    let half = n / 2;
    let mut s = Solver::new(
        implicit,
        contact_params(Vec::new()),
        particles.clone(),
        2e-4,
    );
    let scale: Real = particles.mass.iter().sum::<Real>() * v0;
    let e0 = s.energy();
    let (mut min_gap, mut max_drift, mut contacts) = (Real::INFINITY, 0.0 as Real, 0);
    let mut steps = 0;
    // First contact at t ≈ 0.05 s; the disks have separated well before t = 0.3 s.
    while time(&s) < 0.3 - 1e-9 {
        contacts += s.step();
        steps += 1;
        let p = s.particles();
        max_drift = max_drift.max(momentum(p).norm() / scale);
        let right_min = p.x[half..]
            .iter()
            .map(|x| x.x)
            .fold(Real::INFINITY, Real::min);
        for xa in p.x[..half]
            .iter()
            .filter(|x| x.x > right_min - 2.0 * RADIUS)
        {
            for xb in &p.x[half..] {
                min_gap = min_gap.min((xa - xb).norm());
            }
        }
    }
    let p = s.particles();
    let (va, vb) = (mean_vx(p, 0..half), mean_vx(p, half..n));
    let loss = (e0 - s.energy()) / e0;
    println!(
        "{} disks: {steps} steps, {contacts} contacts, closest pair of different bodies \
         {min_gap:.4} m (r_p + r_q = {:.3} m), momentum drift {max_drift:.2e} of Σ m v0, mean \
         velocities after {va:.3} / {vb:.3} m/s (before ±{v0}), energy loss {:.1}% of E0 = \
         {e0:.3} J",
        s.name(),
        2.0 * RADIUS,
        100.0 * loss
    );
    assert!(contacts > 0);
    assert!(
        min_gap >= 0.5 * (2.0 * RADIUS),
        "interpenetration: {min_gap}"
    );
    assert!(
        max_drift < if implicit { 1e-9 } else { 1e-12 },
        "{max_drift:e}"
    );
    assert!(va < 0.0 && vb > 0.0, "the disks bounce apart: {va}, {vb}");
    assert!((0.0..1.0).contains(&loss), "energy loss {loss}");
}

#[test]
fn colliding_disks_bounce_apart_explicit() {
    colliding_disks(false);
}

#[test]
fn colliding_disks_bounce_apart_implicit() {
    colliding_disks(true);
}

/// A Neo-Hookean block (0.3 m × 0.2 m) dropped from 0.2 m above a wall (the half-space
/// y ≤ 0.1 m) under gravity. Returns nothing; asserts that no particle gets below the wall by
/// more than a contact radius at any time and that the block comes to rest on it.
fn block_on_wall(implicit: bool) {
    let wall = 0.1;
    let bounds = (Vector::<2>::new(0.3, 0.3), Vector::<2>::new(0.6, 0.5));
    let particles = block(
        &grid_around(bounds, DX, 3),
        bounds,
        DX / 2.0,
        1000.0,
        |_| Vector::<2>::zeros(),
    );
    let floor = Obstacle::Collider(ColliderShape::HalfSpace {
        point: Vector::<2>::new(0.0, wall),
        normal: Vector::<2>::new(0.0, 1.0),
    });
    let mut params = contact_params(vec![floor]);
    params.step.gravity = Vector::<2>::new(0.0, -9.81);
    let mut s = Solver::new(implicit, params, particles, 2e-4);
    let (mut lowest, mut contacts, mut peak_speed) = (Real::INFINITY, 0, 0.0 as Real);
    let mut mean_vy = 0.0;
    while time(&s) < 1.0 - 1e-9 {
        contacts += s.step();
        let p = s.particles();
        lowest = p.x.iter().map(|x| x.y).fold(lowest, Real::min);
        mean_vy = p.v.iter().map(|v| v.y).sum::<Real>() / p.len() as Real;
        peak_speed = peak_speed.max(mean_vy.abs());
    }
    let p = s.particles();
    let bottom = p.x.iter().map(|x| x.y).fold(Real::INFINITY, Real::min);
    println!(
        "{} block on wall: {contacts} obstacle contacts, lowest particle ever {lowest:.4} m \
         (wall {wall} m, radius {RADIUS} m), lowest at t = 1 s {bottom:.4} m, mean v_y at \
         t = 1 s {mean_vy:.3} m/s (peak {peak_speed:.3} m/s)",
        s.name()
    );
    assert!(contacts > 0);
    assert!(lowest >= wall - RADIUS, "below the wall: {lowest}");
    assert!(
        bottom > wall - RADIUS && bottom < wall + 2.0 * RADIUS,
        "rests on the wall"
    );
    assert!(mean_vy.abs() < 0.1 * peak_speed, "comes to rest: {mean_vy}");
}

#[test]
fn block_dropped_on_a_wall_stops_above_it_explicit() {
    block_on_wall(false);
}

#[test]
fn block_dropped_on_a_wall_stops_above_it_implicit() {
    block_on_wall(true);
}

fn run_threads(threads: usize, implicit: bool) -> Particles<2> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let walls = Obstacle::Walls {
            min: Vector::<2>::new(0.0, 0.0),
            max: Vector::<2>::new(1.5, 1.0),
        };
        let mut s = Solver::new(implicit, contact_params(vec![walls]), two_disks(2.0), 5e-4);
        let mut contacts = 0;
        for _ in 0..if implicit { 30 } else { 150 } {
            contacts += s.step();
        }
        assert!(contacts > 0, "the scene is in contact");
        s.particles().clone()
    })
}

#[test]
fn contact_results_are_bitwise_identical_for_1_and_4_threads() {
    for implicit in [false, true] {
        assert_eq!(
            run_threads(1, implicit),
            run_threads(4, implicit),
            "implicit: {implicit}"
        );
    }
}

#[test]
fn diagnostics_count_the_contact_potential() {
    // A block 0.1 m × 0.1 m at rest (h = 0.025 m, m_p = 0.625 kg) whose bottom row (4
    // particles at y = 0.0125 m) overlaps the floor y = 0 by δ = r − 0.0125 = 0.0125 m:
    // U_c = 4 · ½ m δ²/dt² = 4 · ½ · 0.625 · 0.0125² / (1e-4)² = 19531.25 J.
    let floor = Obstacle::Collider(ColliderShape::HalfSpace {
        point: Vector::<2>::zeros(),
        normal: Vector::<2>::new(0.0, 1.0),
    });
    let bounds = (Vector::<2>::new(0.4, 0.0), Vector::<2>::new(0.5, 0.1));
    let particles = block(
        &grid_around(bounds, DX, 3),
        bounds,
        DX / 2.0,
        1000.0,
        |_| Vector::<2>::zeros(),
    );
    for implicit in [false, true] {
        let s = Solver::new(
            implicit,
            contact_params(vec![floor]),
            particles.clone(),
            1e-4,
        );
        let (d, dt) = match &s {
            Solver::Explicit(e) => (e.diagnostics(), 1e-4),
            Solver::Implicit(i) => (i.diagnostics(), 5e-4),
        };
        let expected = 4.0 * 0.5 * 0.625 * 0.0125 * 0.0125 / (dt * dt);
        assert!(
            (d.energy(mpm_tlmpm::CONTACT_ENERGY) - expected).abs() < 1e-9 * expected,
            "{}: {} J, expected {expected} J",
            s.name(),
            d.energy(mpm_tlmpm::CONTACT_ENERGY)
        );
        assert_eq!(
            d.total_energy(),
            d.kinetic_energy
                + d.elastic_energy
                + d.potential_energy
                + d.energy(mpm_tlmpm::CONTACT_ENERGY)
        );
    }
}
