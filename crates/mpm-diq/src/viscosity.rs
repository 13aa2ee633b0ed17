//! Implicit Newtonian viscosity of the DIQ fluid.
//!
//! diq-mpm's fluid is inviscid (§4.1, `σ^f = −p^f I`). A fluid material with a dynamic
//! viscosity `μ > 0` adds a viscous solve to the grid update, split off before the pressure
//! projection (the viscous half of the split then sees the predictor `v*`, the projection the
//! viscous result): backward Euler on the linear B-spline (B1) node velocities,
//!
//! ```text
//! (M + Δt K) v = M v*,   (K v)_i = Σ_p V_p μ_p (∇v_p + ∇v_pᵀ) ∇w_i(x_p),   ∇v_p = Σ_j v_j ⊗ ∇w_j(x_p),
//! ```
//!
//! the particle quadrature of the weak form of `∇·(μ (∇v + ∇vᵀ))` over the fluid particles
//! (their whole volume `V_p`, also where the coupling shares their mass with interface points),
//! with traction-free natural boundaries: at walls, colliders and solids the fluid keeps free
//! slip, which the projection then enforces in the normal direction.
//!
//! `K` is the Hessian of the dissipation `Φ(v) = Σ_p V_p μ_p |ε_p|²`, `ε_p = sym ∇v_p`
//! (`vᵀ K v = 2 Φ` is the viscous power), so `M + Δt K` is symmetric positive definite on the
//! nodes with mass and the solve only removes kinetic energy. Its rows sum to zero
//! (`Σ_i ∇w_i = 0`) and `∇v_p + ∇v_pᵀ` is symmetric, so linear and angular momentum are kept
//! to the solver's tolerance. Unconditionally stable: Table 1's `Δt_step` with `μ Δt/(ρ Δx²)` far
//! above 1 is fine.
//!
//! Solved matrix-free by Jacobi-preconditioned CG on vector unknowns from `v*`, to the
//! pressure solve's relative tolerance: each product gathers `∇v_p` per particle, then every
//! node sums `V_p μ_p (∇v_p + ∇v_pᵀ) ∇w_i(x_p)` over the particles of its `2^D` cells in cell
//! and index order, so the result is bitwise the same for any thread count.

use crate::domain::{corner_weights, Domain};
use crate::fluid::Bins;
use crate::pressure::PressureError;
use mpm_core::{Matrix, Real, SolveInfo, Vector};
use mpm_linalg::{
    conjugate_gradient, norm, CgParams, CgWorkspace, InitialGuess, Jacobi, OnIterationCap,
};
use rayon::prelude::*;

/// One particle's part of the viscous operator.
#[derive(Clone, Copy, Debug)]
struct Point<const D: usize> {
    /// Its cell (the first corner node is `corner_node(cell, 0)`).
    cell: [usize; D],
    /// `∇w_j(x_p)` of the cell's `2^D` corners (1/m); only the first `2^D` are used.
    grad: [Vector<D>; 8],
    /// `Δt V_p μ_p` (m^D·Pa·s², so that `coef ∇w ⊗ ∇w` is a mass in kg).
    coef: Real,
}

/// The viscous system `M + Δt K` of one step.
pub(crate) struct Viscous<'a, const D: usize> {
    domain: &'a Domain<D>,
    bins: &'a Bins,
    /// Per fluid particle (the first `points.len()` entries of the binned positions).
    points: Vec<Point<D>>,
    mass: &'a [Real],
}

impl<'a, const D: usize> Viscous<'a, D> {
    /// The system for a step of `dt` (s): particles at `x` (m) with volumes `volume` (m^D) and
    /// viscosities `mu` (Pa·s), the first `x.len()` entries of what `bins` sorted, and the node
    /// masses `mass` (kg). `None` when no particle is viscous.
    pub(crate) fn new(
        domain: &'a Domain<D>,
        bins: &'a Bins,
        (x, volume, mu): (&[Vector<D>], &[Real], &[Real]),
        mass: &'a [Real],
        dt: Real,
    ) -> Option<Self> {
        if !mu.iter().any(|&m| m > 0.0) {
            return None;
        }
        let dx = domain.spec.dx;
        let points = x
            .par_iter()
            .zip(volume)
            .zip(mu)
            .map(|((x, &v), &m)| {
                let (cell, f) = domain.locate(x).expect("particles are clamped inside");
                let mut w = [0.0; 8];
                let mut grad = [Vector::<D>::zeros(); 8];
                corner_weights(&f, dx, &mut w, &mut grad);
                Point {
                    cell,
                    grad,
                    coef: dt * v * m,
                }
            })
            .collect();
        Some(Self {
            domain,
            bins,
            points,
            mass,
        })
    }

    /// `y = (M + Δt K) x` (node velocities in m/s, `y` in kg·m/s).
    fn apply(&self, x: &[Vector<D>], y: &mut [Vector<D>]) {
        let corners = Domain::<D>::CORNERS;
        let stress: Vec<Matrix<D>> = self
            .points
            .par_iter()
            .map(|p| {
                if p.coef == 0.0 {
                    return Matrix::<D>::zeros();
                }
                let mut l = Matrix::<D>::zeros();
                for j in 0..corners {
                    l += x[self.domain.corner_node(&p.cell, j)] * p.grad[j].transpose();
                }
                (l + l.transpose()) * p.coef
            })
            .collect();
        y.par_iter_mut().enumerate().for_each(|(n, y)| {
            *y = x[n] * self.mass[n];
            self.for_each_point(n, |p, j| *y += stress[p] * self.points[p].grad[j]);
        });
    }

    /// The Jacobi inverse diagonal of `M + Δt K`, componentwise (0 on nodes outside the
    /// system).
    fn inverse_diagonal(&self) -> Vec<Vector<D>> {
        (0..self.mass.len())
            .into_par_iter()
            .map(|n| {
                let mut d = Vector::<D>::from_element(self.mass[n]);
                self.for_each_point(n, |p, j| {
                    let (g, c) = (self.points[p].grad[j], self.points[p].coef);
                    for a in 0..D {
                        d[a] += c * (g.norm_squared() + g[a] * g[a]);
                    }
                });
                d.map(|e| if e > 0.0 { 1.0 / e } else { 0.0 })
            })
            .collect()
    }

    /// Calls `f(p, j)` for every viscous particle `p` of the `2^D` cells around node `n`, `j`
    /// being `n`'s corner index in `p`'s cell, in cell then particle order.
    fn for_each_point(&self, n: usize, mut f: impl FnMut(usize, usize)) {
        let spec = &self.domain.spec;
        let node = spec.multi_index(n);
        'corner: for j in 0..Domain::<D>::CORNERS {
            let mut cm = [0usize; D];
            for a in 0..D {
                let k = node[a] - ((j >> a) & 1) as i64;
                if k < 0 || k >= self.domain.cell_dims[a] as i64 {
                    continue 'corner;
                }
                cm[a] = k as usize;
            }
            for &p in self.bins.of(self.domain.cell_index(&cm)) {
                if p < self.points.len() && self.points[p].coef > 0.0 {
                    f(p, j);
                }
            }
        }
    }

    /// Solves `(M + Δt K) v = M v*` in place of `v` (m/s), from `v*`, to `rel_tol` within
    /// `max_iterations` CG iterations.
    pub(crate) fn solve(
        &self,
        v: &mut [Vector<D>],
        (rel_tol, max_iterations): (Real, u32),
    ) -> Result<SolveInfo, PressureError> {
        let rhs: Vec<Vector<D>> = v.iter().zip(self.mass).map(|(v, &m)| v * m).collect();
        let b = norm(&rhs);
        let mut precond = Jacobi::from_inverse_diagonal(self.inverse_diagonal());
        let params = CgParams {
            max_iterations,
            rel_tol,
            abs_tol: 0.0,
            keep_history: false,
            initial_guess: InitialGuess::Given,
            on_cap: OnIterationCap::Error,
        };
        let mut op = |x: &[Vector<D>], y: &mut [Vector<D>]| self.apply(x, y);
        let out = conjugate_gradient(
            &mut op,
            &mut precond,
            &rhs,
            v,
            &params,
            &mut CgWorkspace::default(),
        )
        .map_err(PressureError::Viscosity)?;
        Ok(SolveInfo {
            name: "viscosity",
            iterations: out.iterations,
            residual: if b > 0.0 { out.residual / b } else { 0.0 },
        })
    }
}
