//! Matrix-free Jacobi-preconditioned conjugate gradients on node vectors.
//!
//! Dot products are summed serially in node order and vector updates are element-wise, so the
//! iterates are bitwise independent of the thread count.

use mpm_core::{Real, Vector};
use rayon::prelude::*;

/// Why CG stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum CgEnd {
    /// The relative residual fell below the tolerance.
    Converged,
    /// The iteration cap was reached (the iterate is still a descent direction).
    IterationCap,
    /// `pᵀ A p ≤ 0`: the operator is not positive definite.
    NegativeCurvature,
}

/// CG scratch vectors.
#[derive(Clone, Debug, Default)]
pub(crate) struct CgWork<const D: usize> {
    r: Vec<Vector<D>>,
    z: Vec<Vector<D>>,
    p: Vec<Vector<D>>,
    q: Vec<Vector<D>>,
}

fn dot<const D: usize>(a: &[Vector<D>], b: &[Vector<D>]) -> Real {
    a.iter().zip(b).map(|(x, y)| x.dot(y)).sum()
}

/// Solves `A x = b` from `x = 0` with the preconditioner `diag(inv_diag)`; `apply(x, y)` writes
/// `y = A x`. Stops when `‖b − A x‖₂ ≤ rel_tol ‖b‖₂` or after `max_iterations`. Returns why it
/// stopped and the number of iterations.
pub(crate) fn pcg<const D: usize>(
    mut apply: impl FnMut(&[Vector<D>], &mut [Vector<D>]),
    inv_diag: &[Vector<D>],
    b: &[Vector<D>],
    x: &mut [Vector<D>],
    (rel_tol, max_iterations): (Real, u32),
    w: &mut CgWork<D>,
) -> (CgEnd, u32) {
    let n = b.len();
    for v in [&mut w.r, &mut w.z, &mut w.p, &mut w.q] {
        v.clear();
        v.resize(n, Vector::<D>::zeros());
    }
    x.iter_mut().for_each(|v| *v = Vector::<D>::zeros());
    w.r.copy_from_slice(b);
    let b_norm = dot(b, b).sqrt();
    if b_norm == 0.0 {
        return (CgEnd::Converged, 0);
    }
    w.z.par_iter_mut()
        .zip(&w.r)
        .zip(inv_diag)
        .for_each(|((z, r), d)| *z = r.component_mul(d));
    w.p.copy_from_slice(&w.z);
    let mut rz = dot(&w.r, &w.z);
    for it in 0..max_iterations {
        apply(&w.p, &mut w.q);
        let pq = dot(&w.p, &w.q);
        if pq <= 0.0 || !pq.is_finite() {
            return (CgEnd::NegativeCurvature, it);
        }
        let alpha = rz / pq;
        x.par_iter_mut()
            .zip(&w.p)
            .for_each(|(x, p)| *x += p * alpha);
        w.r.par_iter_mut()
            .zip(&w.q)
            .for_each(|(r, q)| *r -= q * alpha);
        if dot(&w.r, &w.r).sqrt() <= rel_tol * b_norm {
            return (CgEnd::Converged, it + 1);
        }
        w.z.par_iter_mut()
            .zip(&w.r)
            .zip(inv_diag)
            .for_each(|((z, r), d)| *z = r.component_mul(d));
        let rz_new = dot(&w.r, &w.z);
        let beta = rz_new / rz;
        rz = rz_new;
        w.p.par_iter_mut()
            .zip(&w.z)
            .for_each(|(p, z)| *p = z + *p * beta);
    }
    (CgEnd::IterationCap, max_iterations)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_diagonally_scaled_laplacian() {
        // A = diag(s) (tridiagonal Laplacian + I) diag(s) on 2-vectors, per component.
        let n = 200;
        let s: Vec<Real> = (0..n).map(|i| 1.0 + 10.0 * (i % 7) as Real).collect();
        let apply = |x: &[Vector<2>], y: &mut [Vector<2>]| {
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
        let inv_diag: Vec<Vector<2>> = s
            .iter()
            .map(|si| Vector::<2>::from_element(1.0 / (3.0 * si * si)))
            .collect();
        let b: Vec<Vector<2>> = (0..n)
            .map(|i| Vector::<2>::new((i as Real).cos(), 1.0))
            .collect();
        let mut x = vec![Vector::<2>::zeros(); n];
        let (end, it) = pcg(
            apply,
            &inv_diag,
            &b,
            &mut x,
            (1e-12, 500),
            &mut CgWork::default(),
        );
        assert_eq!(end, CgEnd::Converged);
        assert!(it < 100, "{it} iterations");
        let mut ax = vec![Vector::<2>::zeros(); n];
        apply(&x, &mut ax);
        let err: Real = ax
            .iter()
            .zip(&b)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, Real::max);
        assert!(err < 1e-9, "{err}");
    }
}
