//! Scalar and small-matrix maths shared by every solver.
//!
//! The spatial dimension is a const generic `D ∈ {2, 3}`. Operations that nalgebra only offers for
//! concrete sizes (determinant, inverse, signed SVD, polar decomposition and its differential, cross
//! products) sit behind the sealed [`DimOps`] trait, implemented for [`Dim<2>`] and [`Dim<3>`]. Generic
//! code asks for it with the bound `where Dim<D>: DimOps<D>`.

use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector3};

/// The one floating-point type of the workspace.
pub type Real = f64;
/// A spatial vector in `D` dimensions.
pub type Vector<const D: usize> = SVector<Real, D>;
/// A `D × D` matrix (deformation gradients, stresses, affine velocity fields).
pub type Matrix<const D: usize> = SMatrix<Real, D, D>;
/// Angular quantities (angular momentum, torque) are always 3-vectors; in 2D only `z` is non-zero.
pub type Angular = Vector3<Real>;

mod sealed {
    pub trait Sealed {}
    impl Sealed for super::Dim<2> {}
    impl Sealed for super::Dim<3> {}
}

/// Marker type for the spatial dimension; only `Dim<2>` and `Dim<3>` implement [`DimOps`].
#[derive(Clone, Copy, Debug, Default)]
pub struct Dim<const D: usize>;

/// A signed singular value decomposition `F = U diag(σ) Vᵀ` with `U`, `V` proper rotations
/// (`det = +1`). The singular values are sorted in descending order; only the last may be negative,
/// which happens exactly when `det F < 0` (an inverted element).
#[derive(Clone, Copy, Debug)]
pub struct Svd<const D: usize> {
    /// Left rotation.
    pub u: Matrix<D>,
    /// Signed singular values, descending.
    pub sigma: Vector<D>,
    /// Right rotation.
    pub v: Matrix<D>,
}

impl<const D: usize> Svd<D> {
    /// Rebuilds `U diag(σ) Vᵀ`.
    pub fn compose(&self, sigma: &Vector<D>) -> Matrix<D> {
        self.u * Matrix::<D>::from_diagonal(sigma) * self.v.transpose()
    }
}

/// Dimension-specific small-matrix operations (sealed: implemented for `Dim<2>` and `Dim<3>` only).
pub trait DimOps<const D: usize>: sealed::Sealed + Send + Sync + 'static {
    /// Determinant.
    fn det(m: &Matrix<D>) -> Real;
    /// Inverse, or `None` when the matrix is singular.
    fn inverse(m: &Matrix<D>) -> Option<Matrix<D>>;
    /// Signed SVD with proper rotations (see [`Svd`]).
    fn svd(m: &Matrix<D>) -> Svd<D>;
    /// Cross product `a × b` as a 3-vector (2D: `(0, 0, a_x b_y − a_y b_x)`).
    fn cross(a: &Vector<D>, b: &Vector<D>) -> Angular;
    /// Axial vector of the skew part of `m`, `ω_k = ε_kab m_ba`, as a 3-vector
    /// (2D: `(0, 0, m_yx − m_xy)`). `Σ_i w_i d_i × (C d_i) = D · axial(C)` for an isotropic
    /// inertia `Σ w d dᵀ = D I`, which is how APIC particles carry angular momentum.
    fn axial(m: &Matrix<D>) -> Angular;
    /// Differential of the rotation of the polar decomposition `F = R S`: given `R`, the
    /// symmetric factor `S` and a direction `δF`, returns `δR`. Solves `A S + S A = Rᵀ δF − δFᵀ R`
    /// for the skew matrix `A = Rᵀ δR`.
    fn polar_rotation_differential(r: &Matrix<D>, s: &Matrix<D>, df: &Matrix<D>) -> Matrix<D>;
}

/// Polar decomposition `F = R S` with `R` a proper rotation and `S` symmetric (not necessarily
/// positive definite when `det F ≤ 0`), built from the signed SVD.
pub fn polar<const D: usize>(f: &Matrix<D>) -> (Matrix<D>, Matrix<D>)
where
    Dim<D>: DimOps<D>,
{
    let svd = Dim::<D>::svd(f);
    let r = svd.u * svd.v.transpose();
    let s = svd.v * Matrix::<D>::from_diagonal(&svd.sigma) * svd.v.transpose();
    (r, s)
}

/// Determinant of a `D × D` matrix (shorthand for [`DimOps::det`]).
pub fn det<const D: usize>(m: &Matrix<D>) -> Real
where
    Dim<D>: DimOps<D>,
{
    Dim::<D>::det(m)
}

/// Fixes the signs of a raw SVD so that `U` and `V` are proper rotations, moving any reflection
/// into the last (smallest) singular value.
fn sign_fix<const D: usize>(
    mut u: Matrix<D>,
    mut sigma: Vector<D>,
    mut v: Matrix<D>,
    det: fn(&Matrix<D>) -> Real,
) -> Svd<D> {
    // Sort descending (nalgebra sorts, but the contract is ours to keep).
    let mut idx: [usize; D] = std::array::from_fn(|i| i);
    idx.sort_by(|&a, &b| sigma[b].total_cmp(&sigma[a]));
    let (u0, s0, v0) = (u, sigma, v);
    for (k, &i) in idx.iter().enumerate() {
        u.set_column(k, &u0.column(i));
        v.set_column(k, &v0.column(i));
        sigma[k] = s0[i];
    }
    if det(&u) < 0.0 {
        let mut c = u.column_mut(D - 1);
        c.neg_mut();
        sigma[D - 1] = -sigma[D - 1];
    }
    if det(&v) < 0.0 {
        let mut c = v.column_mut(D - 1);
        c.neg_mut();
        sigma[D - 1] = -sigma[D - 1];
    }
    Svd { u, sigma, v }
}

impl DimOps<2> for Dim<2> {
    #[inline]
    fn det(m: &Matrix2<Real>) -> Real {
        m.determinant()
    }
    fn inverse(m: &Matrix2<Real>) -> Option<Matrix2<Real>> {
        m.try_inverse()
    }
    fn svd(m: &Matrix2<Real>) -> Svd<2> {
        let s = m.svd(true, true);
        let (u, vt) = (s.u.unwrap_or_default(), s.v_t.unwrap_or_default());
        sign_fix(u, s.singular_values, vt.transpose(), |m| m.determinant())
    }
    fn cross(a: &SVector<Real, 2>, b: &SVector<Real, 2>) -> Angular {
        Angular::new(0.0, 0.0, a.x * b.y - a.y * b.x)
    }
    fn axial(m: &Matrix2<Real>) -> Angular {
        Angular::new(0.0, 0.0, m[(1, 0)] - m[(0, 1)])
    }
    fn polar_rotation_differential(
        r: &Matrix2<Real>,
        s: &Matrix2<Real>,
        df: &Matrix2<Real>,
    ) -> Matrix2<Real> {
        let m = r.transpose() * df - df.transpose() * r;
        let a = m[(1, 0)] / s.trace();
        r * Matrix2::new(0.0, -a, a, 0.0)
    }
}

impl DimOps<3> for Dim<3> {
    #[inline]
    fn det(m: &Matrix3<Real>) -> Real {
        m.determinant()
    }
    fn inverse(m: &Matrix3<Real>) -> Option<Matrix3<Real>> {
        m.try_inverse()
    }
    fn svd(m: &Matrix3<Real>) -> Svd<3> {
        let s = m.svd(true, true);
        let (u, vt) = (s.u.unwrap_or_default(), s.v_t.unwrap_or_default());
        sign_fix(u, s.singular_values, vt.transpose(), |m| m.determinant())
    }
    fn cross(a: &SVector<Real, 3>, b: &SVector<Real, 3>) -> Angular {
        a.cross(b)
    }
    fn axial(m: &Matrix3<Real>) -> Angular {
        Angular::new(
            m[(2, 1)] - m[(1, 2)],
            m[(0, 2)] - m[(2, 0)],
            m[(1, 0)] - m[(0, 1)],
        )
    }
    fn polar_rotation_differential(
        r: &Matrix3<Real>,
        s: &Matrix3<Real>,
        df: &Matrix3<Real>,
    ) -> Matrix3<Real> {
        // With A = [a]×, [a]× S + S [a]× = [(tr S · I − S) a]×.
        let m = r.transpose() * df - df.transpose() * r;
        let rhs = Vector3::new(m[(2, 1)], m[(0, 2)], m[(1, 0)]);
        let lhs = Matrix3::identity() * s.trace() - s;
        let a = lhs.lu().solve(&rhs).unwrap_or_else(Vector3::zeros);
        r * a.cross_matrix()
    }
}

/// Calls `f` for every multi-index in the box `lo[a] ≤ k[a] < lo[a] + count[a]`, first axis
/// fastest.
pub(crate) fn for_each_index<const D: usize>(
    lo: &[i64; D],
    count: &[usize; D],
    mut f: impl FnMut(&[i64; D]),
) {
    if count.contains(&0) {
        return;
    }
    let mut k = *lo;
    loop {
        f(&k);
        let mut a = 0;
        loop {
            if a == D {
                return;
            }
            k[a] += 1;
            if ((k[a] - lo[a]) as usize) < count[a] {
                break;
            }
            k[a] = lo[a];
            a += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn sample<const D: usize>(seed: u64) -> Matrix<D> {
        let mut s = seed;
        Matrix::<D>::from_fn(|_, _| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as Real / (1u64 << 53) as Real) - 0.5
        }) + Matrix::<D>::identity()
    }

    fn check_svd<const D: usize>()
    where
        Dim<D>: DimOps<D>,
    {
        for seed in 0..20 {
            let mut f = sample::<D>(seed);
            if seed % 3 == 0 {
                f.set_column(0, &(-f.column(0)));
            }
            let svd = Dim::<D>::svd(&f);
            assert_relative_eq!(svd.compose(&svd.sigma), f, epsilon = 1e-12);
            assert_relative_eq!(Dim::<D>::det(&svd.u), 1.0, epsilon = 1e-12);
            assert_relative_eq!(Dim::<D>::det(&svd.v), 1.0, epsilon = 1e-12);
            for k in 0..D - 1 {
                assert!(svd.sigma[k] >= svd.sigma[k + 1].abs() - 1e-14);
                assert!(svd.sigma[k] >= 0.0);
            }
            assert_eq!(svd.sigma[D - 1] < 0.0, Dim::<D>::det(&f) < 0.0);
        }
    }

    fn check_polar_differential<const D: usize>()
    where
        Dim<D>: DimOps<D>,
    {
        for seed in 0..10 {
            let f = sample::<D>(seed);
            let df = sample::<D>(seed + 100) - Matrix::<D>::identity();
            let (r, s) = polar(&f);
            assert_relative_eq!(r * s, f, epsilon = 1e-12);
            let h = 1e-6;
            let (rp, _) = polar(&(f + df * h));
            let (rm, _) = polar(&(f - df * h));
            let fd = (rp - rm) / (2.0 * h);
            let dr = Dim::<D>::polar_rotation_differential(&r, &s, &df);
            assert_relative_eq!(dr, fd, epsilon = 1e-7);
        }
    }

    #[test]
    fn signed_svd_2d_and_3d() {
        check_svd::<2>();
        check_svd::<3>();
    }

    #[test]
    fn polar_differential_matches_finite_differences() {
        check_polar_differential::<2>();
        check_polar_differential::<3>();
    }

    #[test]
    fn axial_vector_matches_cross_products() {
        // Σ over an isotropic set of offsets d of d × (C d) equals |d|²/D-scaled axial(C).
        let c = sample::<3>(7);
        let mut sum = Angular::zeros();
        for a in 0..3 {
            for sgn in [-1.0, 1.0] {
                let mut d = Vector::<3>::zeros();
                d[a] = sgn;
                sum += Dim::<3>::cross(&d, &(c * d));
            }
        }
        // Σ d dᵀ = 2 I here.
        assert_relative_eq!(sum, Dim::<3>::axial(&c) * 2.0, epsilon = 1e-14);
    }
}
