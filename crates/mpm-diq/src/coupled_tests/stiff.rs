//! Blocks dropped into the tank: a stiff block kept rigid by the coupling iteration, and a
//! block that leaves the fluid's box through the floor.

use super::*;

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
    let spec = tank(16);
    let water = lattice(&spec, ([0.0, 0.0], [1.0, water_top]), (0, RHO_F));
    let block = lattice(&spec, block, (1, rho_s)).velocity(v);
    let ps = particles_of(&spec, columns(), &[water, block]);
    DiqCoupled::new(
        spec,
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
