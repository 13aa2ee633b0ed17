//! The quick subset of the multi-grid cases: each at its coarsest resolution, asserting the
//! physics. Bounds were measured (numbers in the comments; the solver is deterministic for any
//! thread count) and given a margin.

use mpm_explicit::DiffusionScheme;
use mpm_validation::cases::multigrid::{
    archimedes, diffusion, drag_max, immiscible, momentum, wall_slide,
};

#[test]
fn maximal_drag_and_full_coupling_reproduce_the_single_grid() {
    let cfg = drag_max::DragMaxConfig {
        duration: 0.15,
        ..drag_max::DragMaxConfig::default()
    };
    let run = drag_max::run(&cfg, 32).unwrap();
    // Measured 3.9e-14 over 0.3 s at Δx = 1/32.
    assert!(run.error < drag_max::TOLERANCE, "{:?}", run.extra);
    assert!(run.extra["max_displacement_m"] > 0.05, "the block moved");
}

#[test]
fn every_coupling_conserves_momentum() {
    for v in &momentum::VARIANTS {
        let d = momentum::drift(32, v).unwrap();
        // Measured 1.1e-15 to 3.1e-15 at Δx = 1/32.
        assert!(
            d.drift < momentum::TOLERANCE,
            "{}: drift {:e}",
            v.key,
            d.drift
        );
        // Measured 0.065 to 0.58.
        assert!(
            d.exchanged > momentum::MIN_EXCHANGE,
            "{}: exchanged {}",
            v.key,
            d.exchanged
        );
    }
}

#[test]
fn frictionless_contact_slides_where_the_single_grid_sticks() {
    let run = wall_slide::run(&wall_slide::SlideConfig::default(), 32).unwrap();
    let r = |k: &str| run.extra[k];
    // Measured at Δx = 1/32: frictionless 0.940, Coulomb δ = 0.5 0.785, single grid 0.105.
    assert!(r("ratio_contact") > 0.92, "{:?}", run.extra);
    assert!(r("ratio_single") < 0.3, "{:?}", run.extra);
    assert!(
        r("ratio_single") < r("ratio_coulomb") && r("ratio_coulomb") < r("ratio_contact"),
        "{:?}",
        run.extra
    );
}

#[test]
fn buoyancy_penalty_separates_immiscible_fluids() {
    let cfg = immiscible::ImmiscibleConfig::default();
    let with = immiscible::separate(&cfg, 32, immiscible::Variant::Contact(2.0)).unwrap();
    let without = immiscible::separate(&cfg, 32, immiscible::Variant::Contact(0.0)).unwrap();
    // Measured at Δx = 1/32: misplaced fraction 0.027 with c_b = 2 (s = 1.10), 0.054 with
    // c_b = 0.
    assert!(with.misplaced < 0.04, "{with:?}");
    assert!(with.separation > immiscible::MIN_SEPARATION, "{with:?}");
    assert!(
        with.misplaced < immiscible::PENALTY_GAIN * without.misplaced,
        "{with:?} {without:?}"
    );
}

#[test]
fn kernel_gradient_diffusion_converges_and_conserves() {
    let cfg = diffusion::DiffusionConfig::default();
    let scheme = DiffusionScheme::KernelGradient;
    let coarse = diffusion::diffuse(&cfg, 16, scheme).unwrap();
    let fine = diffusion::diffuse(&cfg, 32, scheme).unwrap();
    // Measured 3.58e-3 and 1.09e-3; drift 2.4e-15 and 5.0e-15; the particles never move.
    assert!(fine.error < 0.4 * coarse.error, "{coarse:?} {fine:?}");
    assert!(fine.error < 2e-3, "{fine:?}");
    assert!(fine.drift < diffusion::MAX_DRIFT, "{fine:?}");
    assert_eq!(fine.max_speed, 0.0);
    // The MLS-difference scheme (Eqs. 34–35) is reported, not judged: measured error 2.8e-2,
    // drift 1.7e-2 at Δx = 1/32.
    let mls = diffusion::diffuse(&cfg, 32, DiffusionScheme::MlsDifference).unwrap();
    assert!(mls.error < 0.05 && mls.drift < 0.05, "{mls:?}");
}

#[test]
fn floating_block_draft_is_within_a_cell() {
    let cfg = archimedes::FloatConfig::default();
    let dx = 1.0 / 32.0;
    for v in [
        archimedes::Variant::SingleGrid,
        archimedes::Variant::Contact(None),
    ] {
        let f = archimedes::float(&cfg, 32, v).unwrap();
        let cells = (f.draft - cfg.expected_draft()) / dx;
        // Measured −0.57 (single grid) and −0.33 (contact) cells at Δx = 1/32.
        assert!(
            cells.abs() < archimedes::MAX_ERROR_CELLS,
            "{v:?}: {cells} cells"
        );
    }
}
