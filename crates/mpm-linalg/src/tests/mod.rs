//! Checks of the solvers against direct solutions and of the patterns against dense matrices.
//!
//! The checks of the sparse Cholesky factorisation are in `tests/cholesky.rs`, those of the
//! patterns and the DoF map in `tests/pattern.rs`.

mod cholesky;
mod pattern;

use crate::*;
use nalgebra::{DVector, Vector2};

/// `n` deterministic, irregular numbers in [−1, 1]: `sin(seed · (i + 1)²)`.
pub(crate) fn samples(seed: f64, n: usize) -> Vec<f64> {
    (1..=n).map(|i| (seed * (i * i) as f64).sin()).collect()
}

/// Runs `f` in a rayon pool of `threads` threads.
pub(crate) fn in_pool<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// Couplings of the 5-point stencil on an `nx × ny` grid of unknowns, node `i + nx j`.
fn grid_couplings(nx: usize, ny: usize) -> Vec<(usize, usize)> {
    let mut c = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let k = i + nx * j;
            if i + 1 < nx {
                c.push((k, k + 1));
            }
            if j + 1 < ny {
                c.push((k + nx, k));
            }
        }
    }
    c
}

/// The 5-point Dirichlet Laplacian `h⁻² (4 u_k − Σ neighbours)` on an `nx × ny` grid (`ny = 1`
/// gives the 3-point 1D one with diagonal 2).
fn poisson(nx: usize, ny: usize, h: f64) -> SymmetricMatrix {
    let couplings = grid_couplings(nx, ny);
    let pattern = SymmetricPattern::from_couplings(nx * ny, couplings.iter().copied()).unwrap();
    let mut a = SymmetricMatrix::new(pattern);
    let diag = if ny == 1 { 2.0 } else { 4.0 };
    for k in 0..nx * ny {
        a.add(k, k, diag / (h * h)).unwrap();
    }
    for &(i, j) in &couplings {
        a.add(i, j, -1.0 / (h * h)).unwrap();
    }
    a
}

fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let n: f64 = b.iter().map(|y| y * y).sum();
    (d / n).sqrt()
}

fn dense_solve(a: &SymmetricMatrix, b: &[f64]) -> Vec<f64> {
    let lu = a.to_dense().lu();
    lu.solve(&DVector::from_column_slice(b))
        .unwrap()
        .as_slice()
        .to_vec()
}

fn solve<T: Unknown>(
    a: &mut SymmetricMatrix,
    p: &mut impl Preconditioner<T>,
    b: &[T],
    params: &CgParams,
) -> (Result<CgInfo, CgError>, Vec<T>) {
    let mut x = vec![T::zero(); b.len()];
    let info = cg(a, p, b, &mut x, params);
    (info, x)
}

/// [`conjugate_gradient`] with a fresh workspace.
fn cg<T: Unknown>(
    a: &mut impl LinearOperator<T>,
    p: &mut impl Preconditioner<T>,
    b: &[T],
    x: &mut [T],
    params: &CgParams,
) -> Result<CgInfo, CgError> {
    conjugate_gradient(a, p, b, x, params, &mut CgWorkspace::new())
}

fn tight(rel_tol: f64) -> CgParams {
    CgParams {
        rel_tol,
        max_iterations: 10_000,
        ..CgParams::default()
    }
}

#[test]
fn cg_on_1d_poisson_reproduces_the_exact_parabola() {
    // −u'' = 1 on (0, 1), u(0) = u(1) = 0: u = x(1 − x)/2, which the 3-point stencil reproduces
    // exactly at the nodes.
    let n = 99;
    let h = 1.0 / (n + 1) as f64;
    let mut a = poisson(n, 1, h);
    let b = vec![1.0; n];
    let (info, x) = solve(&mut a, &mut Identity, &b, &tight(1e-13));
    let info = info.unwrap();
    let exact: Vec<f64> = (1..=n)
        .map(|i| {
            let x = i as f64 * h;
            0.5 * x * (1.0 - x)
        })
        .collect();
    let err = rel_diff(&x, &exact);
    println!(
        "1D Poisson: {} iterations, error {err:.2e}",
        info.iterations
    );
    assert_eq!(info.stop, CgStop::Converged);
    assert!(err < 1e-11, "{err:e}");
    // A symmetric right-hand side excites only the (n + 1)/2 symmetric eigenvectors, so exact
    // CG ends in that many steps; round-off may add a few.
    assert!(info.iterations <= (n as u32).div_ceil(2) + 5, "{info:?}");
}

#[test]
fn cg_on_2d_poisson_matches_the_direct_solutions() {
    let (nx, ny) = (20, 17);
    let mut a = poisson(nx, ny, 0.05);
    let b = samples(3.1, nx * ny);
    let mut jacobi = Jacobi::new();
    jacobi.set_from_matrix(&a).unwrap();
    let (info, x) = solve(&mut a, &mut jacobi, &b, &tight(1e-12));
    let info = info.unwrap();
    let mut chol = SparseCholesky::new(a.pattern()).unwrap();
    chol.factorize(&a).unwrap();
    let mut x_chol = b.clone();
    chol.solve_in_place(&mut x_chol).unwrap();
    let x_dense = dense_solve(&a, &b);
    // True residual of the CG iterate.
    let mut ax = vec![0.0; b.len()];
    a.mul_vec(&x, &mut ax);
    let true_residual = rel_diff(&ax, &b);
    println!(
        "2D Poisson {nx}×{ny}: {} iterations, CG vs Cholesky {:.2e}, Cholesky vs dense {:.2e}, \
         true relative residual {true_residual:.2e}",
        info.iterations,
        rel_diff(&x, &x_chol),
        rel_diff(&x_chol, &x_dense)
    );
    assert!(true_residual < 2e-12, "{true_residual:e}");
    // κ ≈ 190 bounds the error by κ times the relative residual.
    assert!(rel_diff(&x, &x_chol) < 1e-9);
    assert!(rel_diff(&x_chol, &x_dense) < 1e-13);
}

/// `L = tridiag(−1, 3, −1)` (condition number below 5).
fn shifted_laplacian(n: usize) -> SymmetricMatrix {
    let mut a = poisson(n, 1, 1.0);
    for i in 0..n {
        a.add(i, i, 1.0).unwrap();
    }
    a
}

/// `S L S` for `L` of [`shifted_laplacian`] and `S = diag(s)`, `s` log-uniform in [1, 100].
fn badly_scaled(n: usize) -> (SymmetricMatrix, Vec<f64>) {
    let s: Vec<f64> = samples(1.3, n)
        .iter()
        .map(|r| 10f64.powf(1.0 + r))
        .collect();
    let mut a = shifted_laplacian(n);
    let pattern = a.pattern().clone();
    for c in 0..n {
        for k in pattern.col_ptr()[c]..pattern.col_ptr()[c + 1] {
            let r = pattern.row_idx()[k];
            a.values_mut()[k] *= s[r] * s[c];
        }
    }
    (a, s)
}

#[test]
fn jacobi_removes_the_diagonal_scaling() {
    let n = 300;
    let (mut a, s) = badly_scaled(n);
    let b: Vec<f64> = (0..n).map(|i| s[i] * (0.1 * i as f64).sin()).collect();
    let params = tight(1e-10);
    let (plain, x_plain) = solve(&mut a, &mut Identity, &b, &params);
    let mut jacobi = Jacobi::new();
    jacobi.set_from_matrix(&a).unwrap();
    let (pre, x_pre) = solve(&mut a, &mut jacobi, &b, &params);
    let (plain, pre) = (plain.unwrap(), pre.unwrap());
    // Unscaled reference: with M = diag(A), PCG on S L S is CG on L/3.
    let mut l = shifted_laplacian(n);
    let (unscaled, _) = solve(&mut l, &mut Identity, &b, &params);
    let unscaled = unscaled.unwrap();
    let x_dense = dense_solve(&a, &b);
    println!(
        "S L S (s from 1 to 100): identity {} iterations, Jacobi {}, unscaled L {}",
        plain.iterations, pre.iterations, unscaled.iterations
    );
    assert!(rel_diff(&x_pre, &x_dense) < 1e-6);
    assert!(rel_diff(&x_plain, &x_dense) < 1e-6);
    assert!(
        10 * pre.iterations < plain.iterations,
        "Jacobi {} vs identity {}",
        pre.iterations,
        plain.iterations
    );
    // The preconditioned count is that of the unscaled problem within a few iterations (the
    // stopping test sees the scaled residual).
    assert!(
        pre.iterations.abs_diff(unscaled.iterations) <= 10,
        "{pre:?}"
    );
}

/// `L ⊗ K + I ⊗ M` on blocks of two: the 2D Laplacian coupling every component through the SPD
/// `K`, plus a block-diagonal SPD `M`.
fn block_system(nx: usize, ny: usize) -> SymmetricMatrix {
    let couplings = grid_couplings(nx, ny);
    let pattern = SymmetricPattern::from_block_couplings(nx * ny, 2, couplings).unwrap();
    let k = [[2.0, 0.5], [0.5, 1.0]];
    let m = [[1.0, 0.2], [0.2, 3.0]];
    let mut a = SymmetricMatrix::new(pattern);
    a.refill_block_columns(|col| {
        let i = col.block();
        let (x, y) = (i % nx, i / nx);
        for kk in 0..col.num_blocks() {
            let j = col.block_row(kk);
            let l = if j == i {
                4.0
            } else if (j == i + 1 && x + 1 < nx) || (j == i + nx && y + 1 < ny) {
                -1.0
            } else {
                0.0
            };
            for b in 0..2 {
                for a in 0..2 {
                    if kk == 0 && a < b {
                        continue;
                    }
                    let extra = if kk == 0 { m[a][b] } else { 0.0 };
                    col.add(kk, a, b, l * k[a][b] + extra);
                }
            }
        }
    });
    a
}

#[test]
fn block_unknowns_give_the_scalar_solution() {
    let (nx, ny) = (15, 12);
    let mut a = block_system(nx, ny);
    let n = 2 * nx * ny;
    let b = samples(1.1, n);
    let b_blocks: Vec<Vector2<f64>> = b.chunks(2).map(Vector2::from_column_slice).collect();
    let params = tight(1e-12);
    let mut jacobi = Jacobi::<f64>::new();
    jacobi.set_from_matrix(&a).unwrap();
    let (scalar_info, x) = solve(&mut a, &mut jacobi, &b, &params);
    let mut jacobi_blocks = Jacobi::<Vector2<f64>>::new();
    jacobi_blocks.set_from_matrix(&a).unwrap();
    let (block_info, x_blocks) = solve(&mut a, &mut jacobi_blocks, &b_blocks, &params);
    let (scalar_info, block_info) = (scalar_info.unwrap(), block_info.unwrap());
    let x_flat: Vec<f64> = x_blocks.iter().flat_map(|v| [v[0], v[1]]).collect();
    let x_dense = dense_solve(&a, &b);
    println!(
        "block system n = {n}: scalar {} iterations, block {}, scalar vs block {:.2e}, vs dense \
         {:.2e}",
        scalar_info.iterations,
        block_info.iterations,
        rel_diff(&x_flat, &x),
        rel_diff(&x, &x_dense)
    );
    // Same iterates up to the order of summation inside the dot products.
    assert!(scalar_info.iterations.abs_diff(block_info.iterations) <= 1);
    assert!(rel_diff(&x_flat, &x) < 1e-12);
    assert!(rel_diff(&x, &x_dense) < 1e-10);
}

#[test]
fn matrix_free_block_operator_on_a_scaled_laplacian() {
    // A = diag(s) (tridiagonal Laplacian + I) diag(s) on 2-vectors, per component, as a
    // closure, with the exact inverse diagonal.
    let n = 200;
    let s: Vec<f64> = (0..n).map(|i| 1.0 + 10.0 * (i % 7) as f64).collect();
    let mut apply = |x: &[Vector2<f64>], y: &mut [Vector2<f64>]| {
        for i in 0..n {
            let mut v = x[i] * 3.0 * s[i];
            if i > 0 {
                v -= x[i - 1] * s[i - 1];
            }
            if i + 1 < n {
                v -= x[i + 1] * s[i + 1];
            }
            y[i] = v * s[i];
        }
    };
    let mut jacobi = Jacobi::from_inverse_diagonal(
        s.iter()
            .map(|si| Vector2::from_element(1.0 / (3.0 * si * si)))
            .collect(),
    );
    let b: Vec<Vector2<f64>> = (0..n)
        .map(|i| Vector2::new((i as f64).cos(), 1.0))
        .collect();
    let mut x = vec![Vector2::zeros(); n];
    let info = conjugate_gradient(
        &mut apply,
        &mut jacobi,
        &b,
        &mut x,
        &tight(1e-12),
        &mut CgWorkspace::new(),
    )
    .unwrap();
    let mut ax = vec![Vector2::zeros(); n];
    apply(&x, &mut ax);
    let err = ax
        .iter()
        .zip(&b)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    println!(
        "scaled block Laplacian: {} iterations, max residual {err:.2e}",
        info.iterations
    );
    assert!(info.iterations < 100, "{info:?}");
    assert!(err < 1e-9, "{err:e}");
}

#[test]
fn residual_history_decreases_and_ends_at_the_reported_residual() {
    let (nx, ny) = (30, 30);
    let mut a = poisson(nx, ny, 1.0 / 31.0);
    let b = samples(0.5, nx * ny);
    let params = CgParams {
        keep_history: true,
        ..tight(1e-10)
    };
    let (info, x) = solve(&mut a, &mut Identity, &b, &params);
    let info = info.unwrap();
    let h = &info.history;
    assert_eq!(h.len(), info.iterations as usize + 1);
    assert_eq!(h[0], info.initial_residual);
    assert_eq!(*h.last().unwrap(), info.residual);
    assert_eq!(info.target, 1e-10 * h[0]);
    // The 2-norm of a CG residual is not monotone, but over every stretch of 20 iterations it
    // falls.
    let worst = h.windows(21).map(|w| w[20] / w[0]).fold(0.0, f64::max);
    println!(
        "2D Poisson {nx}×{ny}: {} iterations, worst 20-iteration ratio {worst:.3}",
        info.iterations
    );
    assert!(worst < 1.0, "{worst}");
    // The recursive residual is the true one up to round-off.
    let mut ax = vec![0.0; b.len()];
    a.mul_vec(&x, &mut ax);
    let true_residual: f64 = ax
        .iter()
        .zip(&b)
        .map(|(p, q)| (p - q).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!((true_residual - info.residual).abs() < 1e-3 * info.residual + 1e-14 * h[0]);
}

#[test]
fn the_iteration_cap_is_an_error_or_a_capped_result() {
    let n = 100;
    let mut a = poisson(n, 1, 1.0);
    let b = vec![1.0; n];
    let capped = CgParams {
        max_iterations: 5,
        rel_tol: 1e-10,
        ..CgParams::default()
    };
    let (err, _) = solve(&mut a, &mut Identity, &b, &capped);
    let Err(CgError::NotConverged {
        iterations,
        residual,
        target,
    }) = err
    else {
        panic!("expected NotConverged, got {err:?}");
    };
    assert_eq!(iterations, 5);
    assert_eq!(target, 1e-10 * 10.0);
    let accept = CgParams {
        on_cap: OnIterationCap::Accept,
        ..capped
    };
    let (info, x) = solve(&mut a, &mut Identity, &b, &accept);
    let info = info.unwrap();
    assert_eq!(info.stop, CgStop::IterationCap);
    assert_eq!(info.iterations, 5);
    assert_eq!(info.residual, residual);
    // A truncated CG iterate from zero decreases ½xᵀAx − bᵀx, i.e. bᵀx > 0 along it.
    let bx: f64 = b.iter().zip(&x).map(|(p, q)| p * q).sum();
    assert!(bx > 0.0);
    assert!(err
        .unwrap_err()
        .to_string()
        .contains("did not converge in 5"));
}

#[test]
fn an_indefinite_matrix_gives_negative_curvature() {
    let pattern = SymmetricPattern::from_couplings(2, []).unwrap();
    let mut a = SymmetricMatrix::new(pattern);
    a.add(0, 0, 1.0).unwrap();
    a.add(1, 1, -2.0).unwrap();
    let (err, _) = solve(&mut a, &mut Identity, &[1.0, 1.0], &CgParams::default());
    // p₀ = b: pᵀAp = 1 − 2.
    assert_eq!(
        err,
        Err(CgError::NegativeCurvature {
            iteration: 0,
            curvature: -1.0
        })
    );
    // Shifted 1D Laplacian with one negative eigenvalue: found at a later iteration.
    let n = 50;
    let mut l = poisson(n, 1, 1.0);
    let lambda_min = 2.0 - 2.0 * (std::f64::consts::PI / (n + 1) as f64).cos();
    for i in 0..n {
        l.add(i, i, -1.5 * lambda_min).unwrap();
    }
    let b = vec![1.0; n];
    let (err, _) = solve(&mut l, &mut Identity, &b, &tight(1e-12));
    println!("shifted Laplacian: {err:?}");
    let Err(CgError::NegativeCurvature {
        iteration,
        curvature,
    }) = err
    else {
        panic!("expected NegativeCurvature, got {err:?}");
    };
    assert!(iteration > 0 && curvature <= 0.0);
    let mut jacobi = Jacobi::<f64>::new();
    assert!(matches!(
        jacobi.set_from_matrix(&a),
        Err(CgError::NonPositiveDiagonal { index: 1, value }) if value == -2.0
    ));
}

#[test]
fn wrong_sizes_and_tolerances_are_errors() {
    let mut a = poisson(10, 1, 1.0);
    let b = vec![1.0; 10];
    let default = CgParams::default();
    let err = cg(&mut a, &mut Identity, &b, &mut [0.0; 9], &default);
    assert_eq!(
        err,
        Err(CgError::DimensionMismatch {
            what: "the solution x",
            expected: 10,
            got: 9,
        })
    );
    let mut x = vec![0.0; 10];
    let mut short = Jacobi::from_inverse_diagonal(vec![1.0; 8]);
    let err = cg(&mut a, &mut short, &b, &mut x, &default);
    let Err(CgError::DimensionMismatch { what, got: 8, .. }) = err else {
        panic!("{err:?}");
    };
    assert_eq!(what, "the preconditioner");
    // Four 2-blocks are 8 scalars; the matrix has 10.
    let b2 = vec![Vector2::new(1.0, 1.0); 4];
    let err = cg(
        &mut a,
        &mut Identity,
        &b2,
        &mut [Vector2::zeros(); 4],
        &default,
    );
    assert!(err.unwrap_err().to_string().contains("the operator has 10"));
    let bad = CgParams {
        rel_tol: -1.0,
        ..default
    };
    let err = cg(&mut a, &mut Identity, &b, &mut x, &bad);
    assert!(matches!(
        err,
        Err(CgError::InvalidParameter {
            name: "rel_tol",
            ..
        })
    ));
    let err = cg(&mut a, &mut Identity, &[f64::NAN; 10], &mut x, &default);
    assert!(matches!(err, Err(CgError::NonFinite { iteration: 0, .. })));
}

#[test]
fn a_given_initial_guess_is_used() {
    let n = 60;
    let mut a = poisson(n, 1, 1.0);
    let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.3).cos()).collect();
    let (full, x) = solve(&mut a, &mut Identity, &b, &tight(1e-12));
    let full = full.unwrap();
    // From the solution: nothing to do.
    let mut x0 = x.clone();
    let given = CgParams {
        initial_guess: InitialGuess::Given,
        ..tight(1e-10)
    };
    let mut work = CgWorkspace::new();
    let info = conjugate_gradient(&mut a, &mut Identity, &b, &mut x0, &given, &mut work).unwrap();
    assert_eq!(info.iterations, 0);
    assert_eq!(x0, x);
    assert!(info.initial_residual <= 1e-11 * full.initial_residual);
    // From a perturbed solution: converges back to it.
    let mut x1: Vec<f64> = x
        .iter()
        .zip(samples(0.1, n))
        .map(|(v, r)| v + 1e-3 * r)
        .collect();
    let info = conjugate_gradient(&mut a, &mut Identity, &b, &mut x1, &given, &mut work).unwrap();
    assert!(info.initial_residual > 1e-6 * full.initial_residual);
    assert!(rel_diff(&x1, &x) < 1e-7, "{}", rel_diff(&x1, &x));
}

#[test]
fn solutions_are_bitwise_equal_for_one_and_two_threads() {
    let (nx, ny) = (64, 64);
    let run = |threads: usize| {
        in_pool(threads, || {
            let mut a = poisson(nx, ny, 1.0 / 65.0);
            let b = samples(0.7, nx * ny);
            let mut jacobi = Jacobi::new();
            jacobi.set_from_matrix(&a).unwrap();
            let (info, x) = solve(&mut a, &mut jacobi, &b, &tight(1e-11));
            let mut blocks = block_system(40, 40);
            let bb: Vec<Vector2<f64>> = samples(0.9, 3200)
                .chunks(2)
                .map(Vector2::from_column_slice)
                .collect();
            let mut jb = Jacobi::new();
            jb.set_from_matrix(&blocks).unwrap();
            let (binfo, xb) = solve(&mut blocks, &mut jb, &bb, &tight(1e-11));
            (
                info.unwrap(),
                x,
                binfo.unwrap(),
                xb,
                blocks.values().to_vec(),
            )
        })
    };
    let one = run(1);
    let two = run(2);
    println!(
        "scalar {} iterations, block {} iterations",
        one.0.iterations, one.2.iterations
    );
    assert_eq!(one.0, two.0);
    assert!(one
        .1
        .iter()
        .zip(&two.1)
        .all(|(p, q)| p.to_bits() == q.to_bits()));
    assert_eq!(one.2, two.2);
    assert!(one
        .3
        .iter()
        .zip(&two.3)
        .all(|(p, q)| p.map(f64::to_bits) == q.map(f64::to_bits)));
    assert!(one
        .4
        .iter()
        .zip(&two.4)
        .all(|(p, q)| p.to_bits() == q.to_bits()));
}
