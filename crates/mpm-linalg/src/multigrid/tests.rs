//! Checks of the labelled Poisson operator and its multigrid preconditioner.

use super::*;
use crate::tests::{in_pool, samples};
use crate::{
    conjugate_gradient, dot, CgParams, CgWorkspace, Identity, IncompleteCholesky, Jacobi,
    SparseCholesky,
};

/// Solves `A x = b` on `grid` by CG to `‖r‖ ≤ rel_tol ‖b‖` (x₀ = 0) with the preconditioner
/// `precond`; returns the solution and the iterations.
fn solve<const D: usize, P: Preconditioner<f64>>(
    grid: &PoissonGrid<D>,
    precond: &mut P,
    b: &[f64],
    rel_tol: f64,
) -> (Vec<f64>, u32) {
    let mut op = PoissonOperator::new(grid);
    let mut x = vec![0.0; b.len()];
    let params = CgParams {
        rel_tol,
        max_iterations: 2000,
        ..CgParams::default()
    };
    let info = conjugate_gradient(
        &mut op,
        precond,
        b,
        &mut x,
        &params,
        &mut CgWorkspace::new(),
    )
    .unwrap();
    (x, info.iterations)
}

/// A 2D tank: solid walls outside, air in the top two rows, a solid block in the middle and a
/// few air bubbles.
fn tank_2d() -> PoissonGrid<2> {
    let dims = [13, 11];
    let mut labels = vec![CellLabel::Fluid; 13 * 11];
    for y in 0..11 {
        for x in 0..13 {
            let c = x + 13 * y;
            if y >= 9 || (x, y) == (2, 3) || (x, y) == (10, 5) {
                labels[c] = CellLabel::Air;
            } else if (4..8).contains(&x) && (3..6).contains(&y) {
                labels[c] = CellLabel::Solid;
            }
        }
    }
    PoissonGrid::new(dims, labels, CellLabel::Solid)
        .unwrap()
        .with_coefficient(2.5)
        .unwrap()
}

/// A 3D box with odd sizes: air outside, a solid slab and an air pocket inside.
fn tank_3d() -> PoissonGrid<3> {
    let dims = [9, 8, 7];
    let mut labels = vec![CellLabel::Fluid; 9 * 8 * 7];
    for z in 0..7 {
        for y in 0..8 {
            for x in 0..9 {
                let c = x + 9 * (y + 8 * z);
                if (2..7).contains(&x) && y == 4 && z < 5 {
                    labels[c] = CellLabel::Solid;
                } else if x == 7 && y == 1 && z == 2 {
                    labels[c] = CellLabel::Air;
                }
            }
        }
    }
    PoissonGrid::new(dims, labels, CellLabel::Air)
        .unwrap()
        .with_coefficient(0.7)
        .unwrap()
}

fn mg_params() -> MultigridParams {
    // Coarsen all the way down on the small grids, so several levels are exercised.
    MultigridParams {
        coarsest_cells_per_axis: 2,
        ..MultigridParams::default()
    }
}

fn check_operator_matches_matrix<const D: usize>(grid: &PoissonGrid<D>) {
    let a = grid.assemble().unwrap();
    let n = grid.num_unknowns();
    let mut op = PoissonOperator::new(grid);
    let x = samples(1.3, n);
    let (mut y_op, mut y_mat) = (vec![0.0; n], vec![0.0; n]);
    op.apply(&x, &mut y_op);
    a.mul_vec(&x, &mut y_mat);
    for k in 0..n {
        assert!(
            (y_op[k] - y_mat[k]).abs() <= 1e-13 * (1.0 + y_mat[k].abs()),
            "{k}"
        );
    }
}

#[test]
fn operator_equals_assembled_matrix() {
    let g2 = tank_2d();
    let g3 = tank_3d();
    check_operator_matches_matrix(&g2);
    check_operator_matches_matrix(&g3);
    // The benchmark problem: diagonal 6, off-diagonal −1.
    let b = PoissonGrid::<3>::dirichlet_box([4, 3, 5]).unwrap();
    let a = b.assemble().unwrap();
    assert_eq!(a.diagonal(0), 6.0);
    assert_eq!(a.get(1, 0), -1.0);
    assert_eq!(a.get(4, 0), -1.0);
    assert_eq!(a.get(12, 0), -1.0);
    check_operator_matches_matrix(&b);
    // A solid neighbour drops a diagonal term: the 2D corner cell (0, 0) has two solid faces.
    let a2 = g2.assemble().unwrap();
    assert_eq!(a2.diagonal(0), 2.0 * 2.5);
}

fn check_against_cholesky<const D: usize>(grid: &PoissonGrid<D>) -> u32 {
    let n = grid.num_unknowns();
    let a = grid.assemble().unwrap();
    let mut chol = SparseCholesky::new(a.pattern()).unwrap();
    chol.factorize(&a).unwrap();
    let b = samples(0.37, n);
    let mut exact = b.clone();
    chol.solve_in_place(&mut exact).unwrap();
    let mut mg = MultigridPreconditioner::with_params(grid, mg_params());
    assert!(mg.num_levels() >= 3);
    let (x, iterations) = solve(grid, &mut mg, &b, 1e-10);
    let mut ic0 = IncompleteCholesky::new(&a).unwrap();
    let (x_ic0, _) = solve(grid, &mut ic0, &b, 1e-10);
    let scale = exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for k in 0..n {
        assert!((x_ic0[k] - exact[k]).abs() <= 1e-8 * scale, "IC(0) {k}");
        assert!(
            (x[k] - exact[k]).abs() <= 1e-8 * scale,
            "{k}: {} vs {}",
            x[k],
            exact[k]
        );
    }
    iterations
}

#[test]
fn multigrid_cg_matches_cholesky_2d_and_3d() {
    let it2 = check_against_cholesky(&tank_2d());
    let it3 = check_against_cholesky(&tank_3d());
    // Measured: 2D 14 iterations, 3D 12 to 1e-10.
    assert!(it2 <= 20 && it3 <= 20, "{it2} {it3}");
}

fn check_symmetric_positive<const D: usize>(grid: &PoissonGrid<D>) {
    let n = grid.num_unknowns();
    check_symmetric_positive_precond(
        n,
        &mut MultigridPreconditioner::with_params(grid, mg_params()),
    );
    check_symmetric_positive_precond(
        n,
        &mut IncompleteCholesky::new(&grid.assemble().unwrap()).unwrap(),
    );
}

fn check_symmetric_positive_precond<P: Preconditioner<f64>>(n: usize, mg: &mut P) {
    for seed in [0.3, 1.7, 2.9] {
        let x = samples(seed, n);
        let y = samples(seed + 0.11, n);
        let (mut mx, mut my) = (vec![0.0; n], vec![0.0; n]);
        mg.apply(&x, &mut mx);
        mg.apply(&y, &mut my);
        let (mxy, xmy) = (dot(&mx, &y), dot(&x, &my));
        let scale = dot(&mx, &mx).sqrt() * dot(&y, &y).sqrt();
        assert!((mxy - xmy).abs() <= 1e-13 * scale, "{mxy} vs {xmy}");
        assert!(dot(&mx, &x) > 0.0);
    }
}

#[test]
fn multigrid_is_symmetric_and_positive() {
    check_symmetric_positive(&tank_2d());
    check_symmetric_positive(&tank_3d());
    check_symmetric_positive(&PoissonGrid::<3>::dirichlet_box([16, 16, 16]).unwrap());
}

/// CG iterations to `‖r‖ ≤ 1e-6 ‖b‖` on the 3D Dirichlet box of `n³` cells.
fn iterations<P: Preconditioner<f64>>(n: usize, precond: &mut P) -> u32 {
    let grid = PoissonGrid::<3>::dirichlet_box([n, n, n]).unwrap();
    solve(&grid, precond, &samples(0.9, n * n * n), 1e-6).1
}

#[test]
fn multigrid_needs_far_fewer_iterations_than_jacobi_at_32() {
    let n = 32;
    let grid = PoissonGrid::<3>::dirichlet_box([n, n, n]).unwrap();
    let mut mg = MultigridPreconditioner::new(&grid);
    let mut jacobi = Jacobi::from_inverse_diagonal(vec![1.0 / 6.0; n * n * n]);
    let it_mg = iterations(n, &mut mg);
    let it_jacobi = iterations(n, &mut jacobi);
    let it_id = iterations(n, &mut Identity);
    let a = grid.assemble().unwrap();
    let it_ic0 = iterations(n, &mut IncompleteCholesky::new(&a).unwrap());
    eprintln!("n = 32: multigrid {it_mg}, jacobi {it_jacobi}, identity {it_id}, IC(0) {it_ic0}");
    assert!(it_ic0 < it_jacobi && it_ic0 > it_mg, "IC(0) {it_ic0}");
    assert!(it_mg <= 12, "multigrid {it_mg}");
    assert!(it_jacobi >= 60, "jacobi {it_jacobi}");
}

#[test]
fn multigrid_cg_is_bitwise_identical_for_1_and_2_threads() {
    let run = |threads: usize| {
        in_pool(threads, || {
            let grid = PoissonGrid::<3>::dirichlet_box([40, 36, 34]).unwrap();
            let mut mg = MultigridPreconditioner::new(&grid);
            let b = samples(0.51, grid.num_unknowns());
            let (x, _) = solve(&grid, &mut mg, &b, 1e-8);
            x.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        })
    };
    assert_eq!(run(1), run(2));
}
