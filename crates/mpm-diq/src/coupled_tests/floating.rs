//! Solids in still water: clamped, neutrally buoyant, floating and sinking blocks, a slab on
//! trapped water, the node interface rows at faces and corners, a film sliding down a wall, and
//! bitwise determinism of these scenes.

use super::*;

/// The lowest solid particle's height (m).
fn lowest(s: &DiqCoupled<2>) -> Real {
    let p = s.particles();
    s.solid_indices()
        .iter()
        .map(|&i| p.x[i][1])
        .fold(Real::INFINITY, Real::min)
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
    let inside = move |x: &Vector<2>| (0..2).all(|a| x[a] > lo[a] && x[a] < hi[a]);
    let spec = tank(n);
    let water = lattice(&spec, ([0.0, 0.0], [1.0, 0.75]), (0, RHO_F)).keep(move |x| !inside(x));
    let block = lattice(&spec, (lo, hi), (1, ratio * RHO_F));
    let ps = particles_of(&spec, columns(), &[water, block]);
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
        spec,
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
fn fluid_does_not_enter_a_slab_resting_on_it() {
    // An elastic slab across the whole 2D tank rests on 0.5 m of water: the water is trapped,
    // so the slab must stay where it is and no fluid particle may end inside it (IQ-MPM's
    // position clamping; without it the water rose 0.19 m into the slab within 1 s).
    let n = 16;
    let dx = 1.0 / n as Real;
    let (bottom, thick) = (0.5, 0.25);
    let spec = tank(n);
    let water = lattice(&spec, ([0.0, 0.0], [1.0, bottom]), (0, RHO_F));
    let slab = lattice(&spec, ([0.0, bottom], [1.0, bottom + thick]), (1, 500.0));
    let ps = particles_of(&spec, columns(), &[water, slab]);
    let mut s = DiqCoupled::new(
        spec,
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

#[test]
fn a_block_sinks_onto_the_tank_floor_and_stays_above_it() {
    // ρs = 2000 kg/m² in 0.4 m of water: the block sinks, and the walls, obstacles of Eq. 4's
    // solid–boundary contact, hold it on the floor y = 0.
    let n = 16;
    let dx = 1.0 / n as Real;
    let (x0, x1, bottom) = (0.375, 0.625, 0.125);
    let inside = move |x: &Vector<2>| x[0] > x0 && x[0] < x1 && x[1] > bottom;
    let spec = tank(n);
    let water = lattice(&spec, ([0.0, 0.0], [1.0, 0.4]), (0, RHO_F)).keep(move |x| !inside(x));
    let block = lattice(&spec, ([x0, bottom], [x1, bottom + 0.25]), (1, 2000.0));
    let ps = particles_of(&spec, columns(), &[water, block]);
    let mut solid = SolidParams::<2>::default();
    solid.tlmpm.contact = tank_walls();
    let mut s = DiqCoupled::new(
        spec,
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

#[test]
fn node_rows_hold_the_normal_on_faces_and_both_axes_at_corners() {
    // The clamped block of the test above, its faces on grid lines (Δx = 1/16 m): each node
    // on a face gets one interface row (its normal; the fluid slips along the face), each of
    // the four corner nodes two (a hydrostatic pressure needs both there).
    let n = 16;
    let mut s = submerged(n, (1e8, 1.0), true, InterfaceQuadrature::FluidNodes);
    let (rows, _, _) = s.coupled_problem(5e-3).unwrap();
    let spec = tank(n);
    let mut count = std::collections::BTreeMap::<usize, usize>::new();
    for (k, kind) in rows.kinds().iter().enumerate() {
        if *kind == UnknownKind::Interface {
            *count.entry(rows.anchors()[k]).or_default() += 1;
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
    let spec = tank(n);
    let film = lattice(&spec, ([face, 0.5], [face + 0.1, 0.8]), (0, RHO_F));
    let wall = lattice(&spec, ([0.2, 0.1], [face, 0.9]), (1, 1000.0));
    let ps = particles_of(&spec, columns(), &[film, wall]);
    let tlmpm = mpm_tlmpm::TlmpmParams {
        fixed: vec![mpm_tlmpm::FixedRegion::clamp(
            Vector::<2>::zeros(),
            Vector::<2>::new(face - 3.0 * dx, 1.0),
        )],
        ..mpm_tlmpm::TlmpmParams::default()
    };
    let (g_n, g_t) = (2.0, 9.6);
    let mut p = params::<2>(5e-3, true);
    p.step.gravity = Vector::<2>::new(-g_n, -g_t);
    p.position_correction = false;
    let mut s = DiqCoupled::new(
        spec,
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
    let spec = tank(n);
    let water = lattice(&spec, ([0.0, 0.0], [1.0, depth]), (0, RHO_F));
    let block = lattice(&spec, ([x0, depth], [x1, depth + height]), (1, 500.0));
    let ps = particles_of(&spec, columns(), &[water, block]);
    let mut mats = materials(500.0, 5e4);
    if let Material::Fluid(f) = &mut mats[0] {
        f.viscosity = 50.0;
    }
    let mut p = params::<2>(3e-3, true);
    p.position_correction = false;
    let mut s = DiqCoupled::new(
        spec,
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
