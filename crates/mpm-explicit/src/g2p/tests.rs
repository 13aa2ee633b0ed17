//! Checks of the G2P guard, which names the first bad quantity, and of the row gather, which
//! never returns a negative zero.

use super::*;
use mpm_core::material::{ElasticModel, Lame, SolidMaterial};

/// The guard check names the first bad quantity in the order velocity, position,
/// deformation, inversion, domain, CFL, and passes a good state.
#[test]
fn guard_check_names_the_first_bad_quantity() {
    let spec = GridSpec::<3>::new(Vector::<3>::zeros(), 0.1, [20, 20, 20]);
    let range = spec.stencil_range(Kernel::Quadratic);
    let solid = Material::Solid(SolidMaterial {
        density: 1000.0,
        elastic: ElasticModel::NeoHookean(Lame {
            mu: 1e4,
            lambda: 2e4,
        }),
        plasticity: Default::default(),
    });
    let good = Update::<3> {
        x: Vector::<3>::new(1.0, 0.9, 1.1),
        v: Vector::<3>::new(0.5, -0.25, 0.0),
        c: Matrix::<3>::zeros(),
        f: Matrix::<3>::identity() * 1.01,
        j: 1.01f64.powi(3),
        plastic: PlasticState::default(),
    };
    let dt = 1e-3;
    let check = |u: &Update<3>| check(&spec, &range, &solid, u, dt);
    assert_eq!(check(&good), None);
    let mut u = good;
    u.f[(2, 1)] = Real::NAN;
    assert_eq!(check(&u), Some((Violation::NonFinite("deformation"), u.j)));
    u.x[1] = Real::INFINITY;
    assert_eq!(
        check(&u),
        Some((Violation::NonFinite("position"), Real::INFINITY))
    );
    u.v[2] = Real::NEG_INFINITY;
    assert_eq!(
        check(&u),
        Some((Violation::NonFinite("velocity"), Real::INFINITY))
    );
    let mut u = good;
    u.j = Real::NAN;
    assert!(matches!(check(&u), Some((Violation::NonFinite("deformation"), j)) if j.is_nan()));
    u.j = -0.5;
    assert_eq!(check(&u), Some((Violation::InvertedElement, -0.5)));
    let mut u = good;
    u.x[0] = 0.02;
    assert_eq!(check(&u), Some((Violation::LeftDomain, u.x.norm())));
    let mut u = good;
    u.v[0] = 150.0;
    assert_eq!(check(&u), Some((Violation::CflExceeded, u.v.norm())));
}

/// A window whose velocities are all −0 gathers +0, bit for bit, in every component of v,
/// the FLIP increment and C, in 2D and 3D with both row kernels, as the row sums started
/// from +0 did: the row sums may be −0, but the totals start at +0.
#[test]
fn row_gather_never_returns_negative_zero() {
    fn case<const D: usize, const S: usize>(kernel: Kernel) -> usize {
        let spec = GridSpec::<D>::new(Vector::<D>::zeros(), 0.1, [16; D]);
        let inv_dx = 1.0 / spec.dx;
        let minv = kernel.mls_inertia_inv(spec.dx).unwrap();
        // Positions on two lattices: one of the grid's spacing (at nodes, up to rounding)
        // and one of 0.077 m.
        let x: Vec<Vector<D>> = (0..125)
            .map(|p| {
                Vector::<D>::from_fn(|a, _| {
                    0.4 + 0.1
                        * ((p / 5usize.pow(a as u32)) % 5) as Real
                        * if p % 3 == 0 { 1.0 } else { 0.77 }
                })
            })
            .collect();
        let mut layout = NodeLayout::dense(&spec);
        let mut blocks = Blocks::default();
        layout.begin(&spec);
        blocks.sort(&spec, kernel, &x, None);
        blocks.mark(&mut layout);
        layout.finish();
        let (velocity, old) = (
            vec![Vector::<D>::repeat(-0.0); layout.len()],
            vec![Vector::<D>::zeros(); layout.len()],
        );
        blocks.load_velocities(&layout, &velocity, Some(&old));
        let positive = |m: &[Real]| m.iter().all(|c| c.to_bits() == 0);
        let mut gathered = 0;
        for (p, xp) in x.iter().enumerate() {
            let st = AxisStencil::<D, S>::new(kernel, &spec, inv_dx, xp);
            let win = blocks.velocities(p).unwrap();
            for (v, dv, c) in [
                gather_rows::<D, S, false>(&win, minv, &st),
                gather_rows::<D, S, true>(&win, minv, &st),
            ]
            .into_iter()
            .flatten()
            {
                assert!(
                    positive(v.as_slice()) && positive(dv.as_slice()) && positive(c.as_slice()),
                    "particle {p}: v {v:?}, dv {dv:?}, c {c:?}"
                );
                gathered += 1;
            }
        }
        gathered
    }
    // Every particle's stencil lies in its window, so both forms gather each one.
    assert_eq!(case::<2, 3>(Kernel::Quadratic), 250);
    assert_eq!(case::<3, 3>(Kernel::Quadratic), 250);
    assert_eq!(case::<2, 4>(Kernel::Cubic), 250);
    assert_eq!(case::<3, 4>(Kernel::Cubic), 250);
}
