//! The incremental potential of implicit TLMPM and its derivatives (written here for backward
//! Euler; Newmark changes only the inertia coefficient and the prediction û, see the
//! `implicit` module docs).
//!
//! Unknowns are the node displacements of the step, `u_i = x_i^{n+1} − x_i^n = Δt v_i^{n+1}` (m),
//! on the active nodes of the reference grid. The deformation gradient is affine in them
//! (incremental form of diq-mpm §5.1 step 5, `F^{n+1} = F^n + Δt ∇^X V`):
//!
//! `F_p(u) = F_p^n + Σ_i u_i ⊗ ∇^X W_i(X_p)`,
//!
//! and the potential is
//!
//! `E(u) = Σ_i m_i/(2Δt²) ‖u_i − û_i‖² + Σ_p V⁰_p ψ(F_p(u)) − Σ_i f^ext_i · u_i`
//!
//! with `û_i = Δt v̂_i` the inertial prediction from the transferred momentum and `f^ext`
//! gravity plus the contact forces (both fixed over the step). Its gradient is
//! `∂E/∂u_i = m_i/Δt² (u_i − û_i) − f_i − f^ext_i` with the internal force of Eq. 3,
//! `f_i = −Σ_p V⁰_p P(F_p) ∇^X W_i(X_p)`, and its Hessian is
//! `M/Δt² + K`, `K_ij = Σ_p V⁰_p (∇^X W_i ⊗ I) : ∂P/∂F(F_p) : (∇^X W_j ⊗ I)` built from mpm-core's
//! `dP(F)[δF]`. Since F is affine in u the tangent is exact, which is what Newton's quadratic
//! convergence needs.
//!
//! Per-particle work runs in parallel into per-particle buffers; every per-node sum is a gather
//! over the node's particles in ascending order and every scalar sum is serial, so all results are
//! bitwise independent of the thread count.

use crate::newton::Forces;
use crate::reference::{Constraints, ReferenceConfig, NONE};
use mpm_core::material::{ElasticModel, Hyperelastic};
use mpm_core::{Dim, DimOps, Matrix, Real, Vector};
use nalgebra::SMatrix;
use rayon::prelude::*;

/// The data that defines one step's incremental potential.
pub(crate) struct Potential<'a, const D: usize> {
    /// Cached stencils and node masses.
    pub reference: &'a ReferenceConfig<D>,
    /// Dirichlet data.
    pub constraints: &'a Constraints<D>,
    /// The particles' constitutive law.
    pub law: Constitutive<'a, D>,
    /// Deformation gradients `F^{(r,n)}` since the reference configuration, at the start of
    /// the step.
    pub def_grad: &'a [Matrix<D>],
    /// Inertial prediction û_i = Δt v̂_i (m).
    pub target: &'a [Vector<D>],
    /// External nodal forces (N).
    pub external: &'a [Vector<D>],
    /// Inertia coefficient `c/Δt²` (1/s²) of the term `Σ_i c m_i/(2Δt²) ‖u_i − û_i‖²`: 1/Δt²
    /// for backward Euler, 4/Δt² for Newmark ([`crate::TimeScheme::inertia`]).
    pub inertia: Real,
}

/// The relative change of F whose stress [`Constitutive::stress_scales`] takes as the rounding
/// scale of the stress (dimensionless).
const STIFFNESS_ROUNDOFF: Real = 1e-2;

/// Number of entries of one particle's elasticity tensor, `D⁴`.
pub(crate) const fn tensor_len(d: usize) -> usize {
    d * d * d * d
}

/// `F_p = F_p^n + Σ_i u_i ⊗ ∇^X W_i(X_p)` for every particle.
pub(crate) fn deformation<const D: usize>(
    reference: &ReferenceConfig<D>,
    def_grad: &[Matrix<D>],
    u: &[Vector<D>],
    out: &mut [Matrix<D>],
) {
    out.par_iter_mut().enumerate().for_each(|(p, f)| {
        let (nodes, _, grads) = reference.slots(p);
        *f = def_grad[p];
        for (&i, g) in nodes.iter().zip(grads) {
            if i != NONE {
                *f += u[i as usize] * g.transpose();
            }
        }
    });
}

/// The elastic response of every particle as a function of its deformation gradient
/// `G = F^{(r,n)}` relative to the reference configuration.
///
/// With A-ULMPM each particle carries a base `B_p = F^{(0,r)}_p` (the elastic deformation
/// gradient accumulated up to the reference configuration), and the elastic deformation gradient
/// is `F_E = G B_p`. The energy is integrated over the initial configuration,
/// `Ψ_p(G) = V⁰_p ψ(G B_p)`, so the weighted stress is `∂Ψ_p/∂G = V⁰_p P(G B_p) B_pᵀ` and its
/// differential is `V⁰_p dP(G B_p)[δG B_p] B_pᵀ`; the internal force keeps the form of Eq. 3 on
/// the reference grid. Without a base (`B = I`, plain TLMPM) the code path is the unmodified
/// `V⁰_p P(G)`. Snow hardening enters as a per-particle scale of the Lamé parameters, frozen over
/// the step.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Constitutive<'a, const D: usize> {
    /// Elastic model per material index.
    pub models: &'a [ElasticModel],
    /// Material index per particle.
    pub material: &'a [u32],
    /// Initial particle volumes V⁰ (m^D).
    pub volume0: &'a [Real],
    /// Per-particle base `B_p = F^{(0,r)}_p`; `None` means the identity.
    pub base: Option<&'a [Matrix<D>]>,
    /// Per-particle Lamé scale (plastic hardening, dimensionless); `None` means 1.
    pub hardening: Option<&'a [Real]>,
}

impl<const D: usize> Constitutive<'_, D>
where
    Dim<D>: DimOps<D>,
{
    /// The elastic model of particle `p`, hardening applied.
    #[inline]
    pub fn model(&self, p: usize) -> ElasticModel {
        let m = self.models[self.material[p] as usize];
        match self.hardening {
            Some(s) if s[p] != 1.0 => m.scaled(s[p]),
            _ => m,
        }
    }

    /// The elastic deformation gradient `F_E = G B_p` of particle `p`.
    #[inline]
    pub fn elastic(&self, p: usize, g: &Matrix<D>) -> Matrix<D> {
        match self.base {
            Some(b) => g * b[p],
            None => *g,
        }
    }

    /// `Ψ_p(G) = V⁰_p ψ(G B_p)` (J).
    #[inline]
    pub fn energy(&self, p: usize, g: &Matrix<D>) -> Real {
        self.volume0[p] * self.model(p).psi(&self.elastic(p, g))
    }

    /// `∂Ψ_p/∂G = V⁰_p P(G B_p) B_pᵀ` (N·m).
    #[inline]
    pub fn weighted_stress(&self, p: usize, g: &Matrix<D>) -> Matrix<D> {
        match self.base {
            Some(b) => self.model(p).pk1(&(g * b[p])) * b[p].transpose() * self.volume0[p],
            None => self.model(p).pk1(g) * self.volume0[p],
        }
    }

    /// `V⁰_p dP(G B_p)[δG B_p] B_pᵀ` (N·m per unit δG).
    #[inline]
    pub fn weighted_differential(&self, p: usize, g: &Matrix<D>, dg: &Matrix<D>) -> Matrix<D> {
        match self.base {
            Some(b) => {
                self.model(p).dpk1(&(g * b[p]), &(dg * b[p])) * b[p].transpose() * self.volume0[p]
            }
            None => self.model(p).dpk1(g, dg) * self.volume0[p],
        }
    }

    /// The rounding scale of each particle's weighted stress at `f` (N·m):
    /// `STIFFNESS_ROUNDOFF · V⁰_p (2μ + λ)_p ‖F_p‖`. Near F = I the stress is a difference of
    /// terms of size `V⁰ (2μ + λ) ‖F‖`, so its rounding error is that times a few machine
    /// epsilons however small the stress: a 1 GPa solid at rest has residual forces of about
    /// 1e-8 N that no Newton iteration can remove. Times Newton's round-off fraction (1e-13 by
    /// default), this scale is about 4 ulps of those terms.
    pub fn stress_scales(&self, f: &[Matrix<D>], out: &mut [Real]) {
        out.par_iter_mut().enumerate().for_each(|(p, s)| {
            let lame = self.model(p).lame();
            let stiffness = 2.0 * lame.mu + lame.lambda.abs();
            *s = STIFFNESS_ROUNDOFF * self.volume0[p] * stiffness * self.elastic(p, &f[p]).norm();
        });
    }

    /// `∂Ψ_p/∂G` (N·m) for every particle at `f`.
    pub fn weighted_stresses(&self, f: &[Matrix<D>], out: &mut [Matrix<D>]) {
        out.par_iter_mut().enumerate().for_each(|(p, s)| {
            *s = self.weighted_stress(p, &f[p]);
        });
    }
}

/// Internal force of Eq. 3 on active node `i`, `f_i = −Σ_p V⁰_p P(F_p) ∇^X W_i(X_p)` (N), from
/// the weighted stresses; also returns `Σ_p ‖V⁰_p P_p ∇W_ip‖` (N), the magnitude scale.
#[inline]
pub(crate) fn internal_force<const D: usize>(
    reference: &ReferenceConfig<D>,
    stress: &[Matrix<D>],
    i: usize,
) -> (Vector<D>, Real) {
    let (mut f, mut mag) = (Vector::<D>::zeros(), 0.0);
    for &(p, k) in reference.incidence(i) {
        let t = stress[p as usize] * reference.slot(p as usize, k as usize).1;
        f -= t;
        mag += t.norm();
    }
    (f, mag)
}

impl<const D: usize> Potential<'_, D>
where
    Dim<D>: DimOps<D>,
{
    /// `E(u)` (J) given `f = F(u)`, with the sum of the magnitudes of its terms (J) as the scale
    /// for round-off decisions. `None` when the potential is not finite (e.g. J ≤ 0 for a model
    /// undefined there). `scratch` holds one value per particle.
    pub fn energy(
        &self,
        u: &[Vector<D>],
        f: &[Matrix<D>],
        scratch: &mut [Real],
    ) -> Option<(Real, Real)> {
        scratch.par_iter_mut().enumerate().for_each(|(p, e)| {
            *e = self.law.energy(p, &f[p]);
        });
        let (mut elastic, mut elastic_abs) = (0.0, 0.0);
        for e in scratch.iter() {
            elastic += e;
            elastic_abs += e.abs();
        }
        let (mut inertia, mut work, mut work_abs) = (0.0, 0.0, 0.0);
        let masses = self.reference.node_masses();
        for i in 0..u.len() {
            inertia += 0.5 * masses[i] * self.inertia * (u[i] - self.target[i]).norm_squared();
            let w = self.external[i].dot(&u[i]);
            work += w;
            work_abs += w.abs();
        }
        let value = inertia + elastic - work;
        value
            .is_finite()
            .then_some((value, inertia + elastic_abs + work_abs))
    }

    /// `∇E(u)` (N) into `out`, zero on prescribed components, from the weighted stresses of
    /// `F(u)`. Returns the sizes of the forces in it ([`Forces`]); `magnitude` holds, per node,
    /// the rounding magnitude of its terms and the squared inertial, internal and external
    /// forces on its free components.
    pub fn gradient(
        &self,
        u: &[Vector<D>],
        (stress, stress_scale): (&[Matrix<D>], &[Real]),
        out: &mut [Vector<D>],
        magnitude: &mut [[Real; 4]],
    ) -> Forces {
        let masses = self.reference.node_masses();
        out.par_iter_mut()
            .zip(magnitude.par_iter_mut())
            .enumerate()
            .for_each(|(i, (r, mag))| {
                let scale = masses[i] * self.inertia;
                let mask = &self.constraints.mask[i];
                let inertia = ((u[i] - self.target[i]) * scale).component_mul(mask);
                let (fint, fmag) = internal_force(self.reference, stress, i);
                let (fint, fext) = (
                    fint.component_mul(mask),
                    self.external[i].component_mul(mask),
                );
                *r = inertia - fint - fext;
                // The inertia term is a difference of nearly equal vectors at small dt: its
                // rounding error scales with the magnitudes of both, not with their difference;
                // the internal force's with the stiffness (`Constitutive::stress_scales`).
                let stiff: Real = self
                    .reference
                    .incidence(i)
                    .iter()
                    .map(|&(p, k)| {
                        stress_scale[p as usize]
                            * self.reference.slot(p as usize, k as usize).1.norm()
                    })
                    .sum();
                let rounding = (u[i].norm() + self.target[i].norm()) * scale
                    + self.external[i].norm()
                    + fmag
                    + stiff;
                *mag = [
                    rounding * rounding,
                    inertia.norm_squared(),
                    fint.norm_squared(),
                    fext.norm_squared(),
                ];
            });
        let mut sums = [0.0; 4];
        for m in magnitude.iter() {
            for (s, v) in sums.iter_mut().zip(m) {
                *s += v;
            }
        }
        let [rounding, inertial, internal, external] = sums.map(Real::sqrt);
        Forces {
            rounding,
            inertial,
            internal,
            external,
        }
    }

    /// Per-particle elasticity tensors `V⁰_p ∂P/∂F(F_p)` as `D² × D²` row-major blocks
    /// (`row = a·D + β` for `δP_aβ`, `col = b·D + δ` for `δF_bδ`), symmetrised, and projected to
    /// positive semi-definite when `project`.
    pub fn tensors(&self, f: &[Matrix<D>], project: bool, out: &mut [Real]) {
        let n2 = D * D;
        out.par_chunks_mut(tensor_len(D))
            .enumerate()
            .for_each(|(p, a)| {
                for col in 0..n2 {
                    let mut e = Matrix::<D>::zeros();
                    e[(col / D, col % D)] = 1.0;
                    let dp = self.law.weighted_differential(p, &f[p], &e);
                    for row in 0..n2 {
                        a[row * n2 + col] = dp[(row / D, row % D)];
                    }
                }
                for row in 0..n2 {
                    for col in row + 1..n2 {
                        let s = 0.5 * (a[row * n2 + col] + a[col * n2 + row]);
                        a[row * n2 + col] = s;
                        a[col * n2 + row] = s;
                    }
                }
                if project {
                    project_psd(a, n2);
                }
            });
    }

    /// Matrix-free Hessian product `y = (M/Δt² + K) x` restricted to the free components
    /// (prescribed components of `y` are zero). `scratch` holds one matrix per particle.
    pub fn apply_hessian(
        &self,
        tensors: &[Real],
        x: &[Vector<D>],
        scratch: &mut [Matrix<D>],
        y: &mut [Vector<D>],
    ) {
        let n2 = D * D;
        scratch.par_iter_mut().enumerate().for_each(|(p, dp)| {
            let (nodes, _, grads) = self.reference.slots(p);
            let mut df = Matrix::<D>::zeros();
            for (&i, g) in nodes.iter().zip(grads) {
                if i != NONE {
                    df += x[i as usize] * g.transpose();
                }
            }
            let a = &tensors[p * tensor_len(D)..(p + 1) * tensor_len(D)];
            *dp = Matrix::<D>::from_fn(|r0, r1| {
                let row = &a[(r0 * D + r1) * n2..(r0 * D + r1 + 1) * n2];
                (0..n2).map(|c| row[c] * df[(c / D, c % D)]).sum()
            });
        });
        let masses = self.reference.node_masses();
        y.par_iter_mut().enumerate().for_each(|(i, yi)| {
            let mut acc = x[i] * (masses[i] * self.inertia);
            for &(p, k) in self.reference.incidence(i) {
                acc += scratch[p as usize] * self.reference.slot(p as usize, k as usize).1;
            }
            *yi = acc.component_mul(&self.constraints.mask[i]);
        });
    }

    /// Inverse of the Hessian diagonal (s²/kg) on free components, 0 on prescribed ones (the
    /// Jacobi preconditioner).
    pub fn inverse_diagonal(&self, tensors: &[Real], out: &mut [Vector<D>]) {
        let n2 = D * D;
        let masses = self.reference.node_masses();
        out.par_iter_mut().enumerate().for_each(|(i, di)| {
            let mut d = Vector::<D>::from_element(masses[i] * self.inertia);
            for &(p, k) in self.reference.incidence(i) {
                let a = &tensors[p as usize * tensor_len(D)..];
                let g = self.reference.slot(p as usize, k as usize).1;
                for c in 0..D {
                    for b in 0..D {
                        for e in 0..D {
                            d[c] += g[b] * a[(c * D + b) * n2 + c * D + e] * g[e];
                        }
                    }
                }
            }
            *di = Vector::<D>::from_fn(|c, _| {
                if self.constraints.is_free(i, c) && d[c] > 0.0 {
                    1.0 / d[c]
                } else {
                    0.0
                }
            });
        });
    }
}

/// Replaces the symmetric `n × n` row-major matrix `a` (n = 4 or 9) by its projection onto the
/// positive semi-definite cone (negative eigenvalues clamped to zero).
fn project_psd(a: &mut [Real], n: usize) {
    macro_rules! project {
        ($n:literal) => {{
            let eig = SMatrix::<Real, $n, $n>::from_row_slice(&a[..$n * $n]).symmetric_eigen();
            if eig.eigenvalues.iter().any(|&l| l < 0.0) {
                let l = eig.eigenvalues.map(|l| l.max(0.0));
                let q = eig.eigenvectors;
                let m = q * SMatrix::<Real, $n, $n>::from_diagonal(&l) * q.transpose();
                for r in 0..$n {
                    for c in 0..$n {
                        a[r * $n + c] = 0.5 * (m[(r, c)] + m[(c, r)]);
                    }
                }
            }
        }};
    }
    if n == 4 {
        project!(4)
    } else {
        project!(9)
    }
}
