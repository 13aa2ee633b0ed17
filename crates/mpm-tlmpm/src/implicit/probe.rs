//! The phases of one Newton iteration as separate calls, for the benchmarks of the Newton
//! system (`benches/benches/tlmpm.rs`): only with the `bench` feature. [`ImplicitTlmpm::linearize`]
//! first, then [`ImplicitTlmpm::assemble_tangent`], [`ImplicitTlmpm::factorize_tangent`] and
//! [`ImplicitTlmpm::solve_tangent`] in that order.

use super::{start_step, ImplicitTlmpm, ObjectiveWork};
use crate::assembly::assemble;
use crate::core::{split_law, Core};
use crate::potential::Potential;
use crate::potential::{deformation, tensor_len};
use mpm_core::{Dim, DimOps, Matrix, Real, Vector};
use mpm_linalg::CholeskyError;

impl<const D: usize> ImplicitTlmpm<D>
where
    Dim<D>: DimOps<D>,
{
    /// Linearises the Newton system of a step of `dt` (s) at the initial guess, without advancing
    /// the simulation: runs the P2G, external-force and contact stages, sets the node
    /// displacements to the explicit predictor, and computes the residual `∇E` and the
    /// per-particle elasticity tensors there (exact tangent). Builds the sparsity pattern and the
    /// symbolic factorisation if needed (also with the CG solver). With
    /// [`Self::assemble_tangent`], [`Self::factorize_tangent`] and [`Self::solve_tangent`] this
    /// exposes the phases of one Newton iteration, e.g. for benchmarks.
    pub fn linearize(&mut self, dt: Real) -> Result<(), CholeskyError> {
        self.analyse()?;
        let core = &mut self.core;
        core.momentum_to_grid();
        core.external_forces();
        core.contact(dt);
        let ws = &mut self.ws;
        let scheme = self.implicit.scheme;
        start_step(core, &mut ws.target, &mut ws.objective.stress, scheme, dt);
        let pot = potential(core, &ws.target, scheme.inertia(dt));
        let o = &mut ws.objective;
        let (np, nn) = (core.particles.len(), core.reference.num_nodes());
        o.def_grad.resize(np, Matrix::<D>::zeros());
        deformation(
            pot.reference,
            pot.def_grad,
            &core.displacement,
            &mut o.def_grad,
        );
        o.stress.resize(np, Matrix::<D>::zeros());
        pot.law.weighted_stresses(&o.def_grad, &mut o.stress);
        o.stress_scale.resize(np, 0.0);
        pot.law.stress_scales(&o.def_grad, &mut o.stress_scale);
        ws.probe_residual.resize(nn, Vector::<D>::zeros());
        o.magnitude.resize(nn, [0.0; 4]);
        pot.gradient(
            &core.displacement,
            (&o.stress, &o.stress_scale),
            &mut ws.probe_residual,
            &mut o.magnitude,
        );
        o.tensors.resize(np * tensor_len(D), 0.0);
        pot.tensors(&o.def_grad, false, &mut o.tensors);
        ws.probe_dt = dt;
        Ok(())
    }

    /// Assembles the sparse Newton matrix `c M/Δt² + K` (lower triangle; c = 1 for backward Euler,
    /// 4 for Newmark) from the tensors of the
    /// last [`Self::linearize`].
    pub fn assemble_tangent(&mut self) -> Result<(), CholeskyError> {
        let inertia = self.implicit.scheme.inertia(self.ws.probe_dt);
        let pot = potential(&self.core, &self.ws.target, inertia);
        let ObjectiveWork {
            sparse, tensors, ..
        } = &mut self.ws.objective;
        let sys = sparse.as_mut().ok_or(CholeskyError::NotFactorized)?;
        assemble(&pot, tensors, &mut sys.matrix);
        Ok(())
    }

    /// Numeric Cholesky factorisation of the last assembled Newton matrix (the symbolic
    /// factorisation is reused), in f32 when `single` (see [`crate::NewtonParams::single_precision`]),
    /// else in f64.
    pub fn factorize_tangent(&mut self, single: bool) -> Result<(), CholeskyError> {
        let sys = self.ws.objective.sparse.as_mut();
        let sys = sys.ok_or(CholeskyError::NotFactorized)?;
        if single {
            sys.cholesky.factorize_single(&sys.matrix)
        } else {
            sys.cholesky.factorize(&sys.matrix)
        }
    }

    /// Solves `H d = −∇E` with the last factorisation (triangular solves) and returns `‖d‖₂`
    /// (m), the length of the Newton step.
    pub fn solve_tangent(&mut self) -> Result<Real, CholeskyError> {
        let sys = self.ws.objective.sparse.as_mut();
        let sys = sys.ok_or(CholeskyError::NotFactorized)?;
        let r = &self.ws.probe_residual;
        for (e, &j) in self.core.constraints.dofs.nodes().iter().enumerate() {
            for a in 0..D {
                sys.rhs[e * D + a] = -r[j][a];
            }
        }
        sys.cholesky.solve_in_place(&mut sys.rhs)?;
        Ok(sys.rhs.iter().map(|x| x * x).sum::<Real>().sqrt())
    }
}

/// The incremental potential of a step with inertia coefficient `inertia` (1/s², see
/// [`TimeScheme::inertia`]) and inertial prediction `target` (m) at the solver's current state.
fn potential<'a, const D: usize>(
    core: &'a Core<D>,
    target: &'a [Vector<D>],
    inertia: Real,
) -> Potential<'a, D> {
    let (law, def_grad) = split_law(&core.models, &core.particles, core.adaptive.as_ref());
    Potential {
        reference: &core.reference,
        constraints: &core.constraints,
        law,
        def_grad,
        target,
        external: &core.external,
        inertia,
    }
}
