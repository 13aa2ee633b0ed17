//! The unknowns a linear solver works on: scalars or fixed-size blocks of scalars.

use nalgebra::SVector;
use rayon::prelude::*;
use std::fmt::Debug;
use std::ops::{Add, AddAssign, Mul};

/// Slices shorter than this are updated by one task (element-wise updates only; the split
/// never changes a result).
const MIN_TASK_LEN: usize = 512;

/// One unknown of a linear system: a scalar `f64`, or a block `SVector<f64, B>` of `B` scalars
/// (for example the displacement of one grid node). The conjugate-gradient solver, the
/// preconditioners and the sparse matrix product see slices of unknowns only through these
/// operations, so one implementation serves scalar and block systems. Scalar component `s` of a
/// slice is component `s % LEN` of unknown `s / LEN`.
pub trait Unknown:
    Copy
    + Send
    + Sync
    + PartialEq
    + Debug
    + Add<Output = Self>
    + AddAssign
    + Mul<f64, Output = Self>
    + 'static
{
    /// Number of scalar components.
    const LEN: usize;
    /// The zero unknown.
    fn zero() -> Self;
    /// Euclidean inner product of the components.
    fn dot(&self, other: &Self) -> f64;
    /// `self ← self + x·alpha`, component by component.
    #[inline]
    fn axpy(&mut self, alpha: f64, x: &Self) {
        *self += *x * alpha;
    }
    /// `self ← x + self·beta`, component by component.
    #[inline]
    fn xpay(&mut self, x: &Self, beta: f64) {
        *self = *x + *self * beta;
    }
    /// The component-wise product.
    fn mul_elementwise(&self, other: &Self) -> Self;
    /// Component `k` (`k < LEN`; panics otherwise).
    fn component(&self, k: usize) -> f64;
    /// Mutable component `k` (`k < LEN`; panics otherwise).
    fn component_mut(&mut self, k: usize) -> &mut f64;
}

impl Unknown for f64 {
    const LEN: usize = 1;

    #[inline]
    fn zero() -> Self {
        0.0
    }

    #[inline]
    fn dot(&self, other: &Self) -> f64 {
        self * other
    }

    #[inline]
    fn mul_elementwise(&self, other: &Self) -> Self {
        self * other
    }

    #[inline]
    fn component(&self, k: usize) -> f64 {
        assert_eq!(k, 0, "a scalar unknown has one component");
        *self
    }

    #[inline]
    fn component_mut(&mut self, k: usize) -> &mut f64 {
        assert_eq!(k, 0, "a scalar unknown has one component");
        self
    }
}

impl<const B: usize> Unknown for SVector<f64, B> {
    const LEN: usize = B;

    #[inline]
    fn zero() -> Self {
        Self::zeros()
    }

    #[inline]
    fn dot(&self, other: &Self) -> f64 {
        nalgebra::Matrix::dot(self, other)
    }

    #[inline]
    fn mul_elementwise(&self, other: &Self) -> Self {
        self.component_mul(other)
    }

    #[inline]
    fn component(&self, k: usize) -> f64 {
        self[k]
    }

    #[inline]
    fn component_mut(&mut self, k: usize) -> &mut f64 {
        &mut self[k]
    }
}

/// `Σ_i a_i · b_i`, summed serially in index order, so the result does not depend on the number
/// of threads. Panics when the lengths differ.
pub fn dot<T: Unknown>(a: &[T], b: &[T]) -> f64 {
    assert_eq!(
        a.len(),
        b.len(),
        "dot product of slices of different lengths"
    );
    a.iter().zip(b).map(|(x, y)| x.dot(y)).sum()
}

/// The Euclidean norm `(Σ_i a_i · a_i)^½`, summed like [`dot`].
pub fn norm<T: Unknown>(a: &[T]) -> f64 {
    dot(a, a).sqrt()
}

/// Scalar component `s` of a slice of unknowns.
#[inline]
pub(crate) fn scalar<T: Unknown>(v: &[T], s: usize) -> f64 {
    v[s / T::LEN].component(s % T::LEN)
}

/// Mutable scalar component `s` of a slice of unknowns.
#[inline]
pub(crate) fn scalar_mut<T: Unknown>(v: &mut [T], s: usize) -> &mut f64 {
    v[s / T::LEN].component_mut(s % T::LEN)
}

/// `y ← y + x·alpha`, element-wise in parallel.
pub(crate) fn par_axpy<T: Unknown>(y: &mut [T], alpha: f64, x: &[T]) {
    y.par_iter_mut()
        .with_min_len(MIN_TASK_LEN)
        .zip(x)
        .for_each(|(y, x)| y.axpy(alpha, x));
}

/// `y ← x + y·beta`, element-wise in parallel.
pub(crate) fn par_xpay<T: Unknown>(y: &mut [T], x: &[T], beta: f64) {
    y.par_iter_mut()
        .with_min_len(MIN_TASK_LEN)
        .zip(x)
        .for_each(|(y, x)| y.xpay(x, beta));
}

/// `z ← r ⊙ d`, element-wise in parallel.
pub(crate) fn par_mul_elementwise<T: Unknown>(z: &mut [T], r: &[T], d: &[T]) {
    z.par_iter_mut()
        .with_min_len(MIN_TASK_LEN)
        .zip(r)
        .zip(d)
        .for_each(|((z, r), d)| *z = r.mul_elementwise(d));
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn block_operations_act_per_component() {
        let mut y = Vector3::new(1.0, -2.0, 0.5);
        let x = Vector3::new(4.0, 1.0, -8.0);
        Unknown::axpy(&mut y, 0.25, &x);
        assert_eq!(y, Vector3::new(2.0, -1.75, -1.5));
        y.xpay(&x, 2.0);
        assert_eq!(y, Vector3::new(8.0, -2.5, -11.0));
        assert_eq!(y.dot(&x), 32.0 - 2.5 + 88.0);
        assert_eq!(y.mul_elementwise(&x), Vector3::new(32.0, -2.5, 88.0));
        *y.component_mut(2) = 7.0;
        assert_eq!(y.component(2), 7.0);
        let v = [Vector3::new(1.0, 2.0, 3.0), Vector3::new(4.0, 5.0, 6.0)];
        assert_eq!(scalar(&v, 4), 5.0);
        assert_eq!(norm(&v), 91.0f64.sqrt());
        let mut s = 3.0;
        s.axpy(-2.0, &0.5);
        assert_eq!(s, 2.0);
        s.xpay(&1.0, 3.0);
        assert_eq!(s, 7.0);
    }
}
