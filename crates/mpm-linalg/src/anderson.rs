//! Anderson acceleration of fixed-point iterations `f ← T(f)` on slices of [`Unknown`]s.

use crate::unknown::{dot, Unknown};
use nalgebra::{DMatrix, DVector};

/// Anderson acceleration of a fixed-point iteration `f ← T(f)` (Walker & Ni 2011, type II, no
/// damping): with the residuals `r = T(f) − f` of the last `depth + 1` passes, the next iterate
/// is `T(f_k) − ΔG γ` with `γ` minimising `‖r_k − ΔR γ‖₂` (`ΔR`, `ΔG` the differences of
/// successive residuals and images; the small least-squares problem is solved by its normal
/// equations with a ridge of 10⁻¹² of their trace). On an affine map this is GMRES on its
/// fixed-point equation, so it converges where the plain iteration or a scalar relaxation
/// crawls (the coupled DIQ step's partitioned iteration: a stiff solid's interface modes
/// contract by only `1 − m_node/m_body` per plain pass). Sums run in index order: results do
/// not depend on the thread count.
#[derive(Clone, Debug)]
pub struct Anderson<U: Unknown> {
    depth: usize,
    /// The last iterates' residuals `r` and images `g = T(f)`, oldest first.
    history: Vec<(Vec<U>, Vec<U>)>,
}

impl<U: Unknown> Default for Anderson<U> {
    /// Depth 5.
    fn default() -> Self {
        Self::new(5)
    }
}

impl<U: Unknown> Anderson<U> {
    /// An accelerator keeping `depth` differences (0 is the plain iteration).
    pub fn new(depth: usize) -> Self {
        Self {
            depth,
            history: Vec::new(),
        }
    }

    /// The update `f_{k+1} − f_k` from the current iterate `current` and its image
    /// `target = T(current)` (same length).
    pub fn step(&mut self, current: &[U], target: &[U]) -> Vec<U> {
        let r: Vec<U> = target.iter().zip(current).map(|(t, c)| sub(t, c)).collect();
        self.history.push((r.clone(), target.to_vec()));
        if self.history.len() > self.depth + 1 {
            self.history.remove(0);
        }
        let m = self.history.len() - 1;
        let diff = |k: usize, image: bool| -> Vec<U> {
            let (a, b) = (&self.history[k], &self.history[k + 1]);
            let (a, b) = if image { (&a.1, &b.1) } else { (&a.0, &b.0) };
            b.iter().zip(a).map(|(b, a)| sub(b, a)).collect()
        };
        let dr: Vec<Vec<U>> = (0..m).map(|k| diff(k, false)).collect();
        let mut normal = DMatrix::<f64>::zeros(m, m);
        let mut rhs = DVector::<f64>::zeros(m);
        for a in 0..m {
            for b in 0..m {
                normal[(a, b)] = dot(&dr[a], &dr[b]);
            }
            rhs[a] = dot(&dr[a], &r);
        }
        let ridge = 1e-12 * normal.trace().max(f64::MIN_POSITIVE);
        for a in 0..m {
            normal[(a, a)] += ridge;
        }
        let gamma = normal
            .cholesky()
            .map(|c| c.solve(&rhs))
            .unwrap_or_else(|| DVector::zeros(m));
        let mut next = target.to_vec();
        for k in 0..m {
            let dg = diff(k, true);
            for (f, d) in next.iter_mut().zip(&dg) {
                *f = sub(f, &(*d * gamma[k]));
            }
        }
        next.iter().zip(current).map(|(n, c)| sub(n, c)).collect()
    }
}

/// `a − b` (exactly `a + (−1)·b` in floating point).
fn sub<U: Unknown>(a: &U, b: &U) -> U {
    *a + *b * -1.0
}

#[cfg(test)]
mod tests {
    use super::Anderson;
    use nalgebra::SVector;

    type V2 = SVector<f64, 2>;

    /// An affine contraction `T(f) = A f + b` on three 2-vectors, `A` diagonal with the rates of
    /// a stiff solid's slow interface modes (0.99) down to 0; its fixed point is `b/(1 − a)`.
    fn map(f: &[V2]) -> Vec<V2> {
        let a = [0.99, 0.9, 0.5, 0.2, 0.1, 0.0];
        (0..3)
            .map(|k| V2::from_fn(|c, _| a[2 * k + c] * f[k][c] + 1.0))
            .collect()
    }

    fn error(f: &[V2]) -> f64 {
        let a = [0.99, 0.9, 0.5, 0.2, 0.1, 0.0];
        (0..6)
            .map(|i| (f[i / 2][i % 2] - 1.0 / (1.0 - a[i])).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn anderson_solves_an_affine_fixed_point_where_the_plain_iteration_crawls() {
        let (mut plain, mut fast) = (vec![V2::zeros(); 3], vec![V2::zeros(); 3]);
        let mut acc = Anderson::<V2>::default();
        for _ in 0..10 {
            plain = map(&plain);
            let delta = acc.step(&fast, &map(&fast));
            for (f, d) in fast.iter_mut().zip(&delta) {
                *f += d;
            }
        }
        // On an affine map Anderson behaves like GMRES: ten passes resolve the six rates; the
        // plain iteration is still 90 % short on the 0.99 mode (error 0.99¹⁰ · 100 = 90).
        assert!(error(&fast) < 1e-8, "Anderson: {:e}", error(&fast));
        assert!(error(&plain) > 80.0, "plain: {:e}", error(&plain));
    }

    /// Depth 0 is the plain iteration: the update is `T(f) − f`.
    #[test]
    fn depth_zero_is_the_plain_iteration() {
        let mut acc = Anderson::<f64>::new(0);
        let f = [1.0, 2.0];
        for _ in 0..3 {
            let d = acc.step(&f, &[4.0, -1.0]);
            assert_eq!(d, vec![3.0, -3.0]);
        }
    }
}
