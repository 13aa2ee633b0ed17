//! Helpers shared by the unit tests of this crate.

use crate::math::{polar, Dim, DimOps, Matrix, Real};

/// Deterministic uniform numbers in [0, 1) from a 64-bit LCG, and random matrices built on them.
pub(crate) struct Lcg(pub u64);

impl Lcg {
    /// Next number in [0, 1).
    pub fn next(&mut self) -> Real {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as Real / (1u64 << 53) as Real
    }

    /// Entries uniform in [−a, a].
    pub fn matrix<const D: usize>(&mut self, a: Real) -> Matrix<D> {
        Matrix::<D>::from_fn(|_, _| a * (2.0 * self.next() - 1.0))
    }

    /// A random proper rotation.
    pub fn rotation<const D: usize>(&mut self) -> Matrix<D>
    where
        Dim<D>: DimOps<D>,
    {
        polar(&self.matrix::<D>(1.0)).0
    }
}
