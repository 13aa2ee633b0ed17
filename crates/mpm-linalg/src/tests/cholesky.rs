//! Checks of the sparse Cholesky factorisation against dense solves, in double and single
//! precision, and of its errors.

use super::*;

#[test]
fn single_precision_factor_solves_to_the_condition_number_times_f32_rounding() {
    let (nx, ny) = (20, 17);
    let a = poisson(nx, ny, 0.05);
    let b = samples(3.1, nx * ny);
    let x_dense = dense_solve(&a, &b);
    let mut chol = SparseCholesky::new(a.pattern()).unwrap();
    chol.factorize_single(&a).unwrap();
    assert_eq!(chol.factored(), Some(Precision::Single));
    let mut x = b.clone();
    chol.solve_in_place(&mut x).unwrap();
    let single = rel_diff(&x, &x_dense);
    chol.factorize(&a).unwrap();
    assert_eq!(chol.factored(), Some(Precision::Double));
    let mut x = b.clone();
    chol.solve_in_place(&mut x).unwrap();
    let double = rel_diff(&x, &x_dense);
    println!("2D Poisson {nx}×{ny}: f32 factor {single:.2e}, f64 factor {double:.2e}");
    // κ ≈ 190 and the f32 unit roundoff 6e-8 bound the f32 error by about 1e-5; it must be
    // an f32 solve (above f64 rounding) and the f64 one must stay at f64 rounding.
    assert!(single < 190.0 * 6e-8 && single > 1e-10, "{single:e}");
    assert!(double < 1e-13, "{double:e}");
    // A failed factorisation leaves none, in either precision.
    let mut indefinite = a.clone();
    indefinite.add(0, 0, -1e4).unwrap();
    assert!(chol.factorize_single(&indefinite).is_err());
    assert_eq!(chol.factored(), None);
    assert_eq!(
        chol.solve_in_place(&mut x),
        Err(CholeskyError::NotFactorized)
    );
}

#[test]
fn cholesky_matches_a_dense_solve_and_reuses_the_analysis() {
    let (nx, ny) = (12, 9);
    let mut a = block_system(nx, ny);
    let n = a.pattern().dim();
    let mut chol = SparseCholesky::new(a.pattern()).unwrap();
    assert_eq!((chol.dim(), chol.nnz()), (n, a.pattern().nnz()));
    assert!(chol.factor_nnz() >= chol.nnz());
    let b = samples(0.2, n);
    for shift in [0.0, 5.0] {
        for i in 0..n {
            a.add(i, i, shift).unwrap();
        }
        chol.factorize(&a).unwrap();
        let mut x = b.clone();
        chol.solve_in_place(&mut x).unwrap();
        let dense = a.to_dense().cholesky().unwrap();
        let xd = dense.solve(&DVector::from_column_slice(&b));
        let err = rel_diff(&x, xd.as_slice());
        println!("shift {shift}: sparse vs dense Cholesky {err:.2e}");
        assert!(err < 1e-13, "{err:e}");
    }
    // Errors are reported, not panicked on.
    assert_eq!(
        chol.solve_in_place(&mut vec![0.0; n - 1]),
        Err(CholeskyError::WrongLength {
            expected: n,
            got: n - 1
        })
    );
    let mut indefinite = a.clone();
    indefinite.add(4, 4, -1e3).unwrap();
    assert!(matches!(
        chol.factorize(&indefinite),
        Err(CholeskyError::NotPositiveDefinite { .. })
    ));
    assert_eq!(
        chol.solve_in_place(&mut vec![0.0; n]),
        Err(CholeskyError::NotFactorized)
    );
    let other = block_system(nx, ny);
    assert_eq!(chol.factorize(&other), Err(CholeskyError::PatternMismatch));
}
