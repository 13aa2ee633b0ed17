//! A-ULMPM (Su et al. 2021; diq-mpm §5.4): adaptive updates of the reference configuration,
//! with the elasto-plastic return mapping of snow and sand.
//!
//! Each particle keeps two deformation gradients:
//!
//! * `G_p = F_p^{(r,n)}`, the *kinematic* deformation gradient from the reference configuration
//!   `r` to the current one. It is updated in incremental form on the reference grid,
//!   `G^{n+1} = G^n + Σ_i u_i ⊗ ∇^{X_r} W_i(X^r_p)`, exactly as TLMPM updates F, and it drives the
//!   trigger `δJ_p = |det G_p − 1|`.
//! * `B_p = F_p^{(0,r)}`, the *base*: the elastic deformation gradient accumulated up to the
//!   reference configuration, so that the elastic deformation gradient is `F_E = G B`
//!   (for elastic solids `B = F^{(0,r)}` and `F_E = F^{(r,n)} F^{(0,r)} = F^{(0,n)}`, the total
//!   deformation gradient).
//!
//! **Composition with the incremental update.** With `∇^{X_r} u = ∇_x u · G^n` the
//! updated-Lagrangian trial state `F_E^{trial} = (I + ∇_x u) F_E^n` equals `G^{n+1} B`: the
//! incremental update of `G` with a fixed `B` *is* the trial elastic update. For elastic solids
//! nothing else happens. For plastic solids the return mapping projects the total elastic
//! `F_E = Z(G^{n+1} B)` (snow: clamped singular values; sand: Drucker–Prager), and the plastic
//! flow is moved into the base, `B ← (G^{n+1})⁻¹ F_E`, so that `G` stays kinematic and
//! `G B = F_E` holds after every step. The plastic state is frozen during the grid solve (the
//! implicit solver minimises the elastic potential with the hardened Lamé parameters of the
//! start of the step, then projects), the usual semi-implicit treatment of plasticity.
//!
//! **Reference update.** When the trigger fires after an accepted step, the current positions
//! become the reference positions, the weights, gradients, node masses, connectivity and
//! Dirichlet numbering are rebuilt (and, in the implicit solver, the sparsity pattern and the
//! symbolic factorisation), and `B ← F_E`, `G ← I`. The APIC affine field `C = ∇^{X_r} V` is
//! re-expressed on the new reference, `C ← C G⁻¹`. Particle masses and initial volumes `V⁰` do
//! not change, so mass is conserved exactly and the energy stays `Σ_p V⁰_p ψ(F_E)`.

use crate::params::ReferenceUpdate;
use crate::transfer::Update;
use mpm_core::material::{PlasticState, Plasticity};
use mpm_core::{Dim, DimOps, Location, Material, Matrix, Real, Violation};
use rayon::prelude::*;

/// The A-ULMPM state of all particles.
#[derive(Clone, Debug)]
pub(crate) struct Adaptive<const D: usize> {
    /// The trigger.
    pub trigger: ReferenceUpdate,
    /// `G_p = F_p^{(r,n)}`, deformation gradients since the reference configuration.
    pub rel: Vec<Matrix<D>>,
    /// `B_p = F_p^{(0,r)}`; `None` while it is the identity (no update and no plastic flow yet).
    pub base: Option<Vec<Matrix<D>>>,
    /// Per-particle Lamé scale from snow hardening, frozen over a step; `None` without snow.
    pub hardening: Option<Vec<Real>>,
    /// G2P results awaiting commit: elastic deformation gradient, base and plastic state.
    pub pending: Vec<(Matrix<D>, Matrix<D>, PlasticState)>,
    /// Number of reference updates so far.
    pub updates: u64,
}

impl<const D: usize> Adaptive<D>
where
    Dim<D>: DimOps<D>,
{
    /// The state at set-up: `G = F` (the particles' deformation gradients), `B = I`.
    pub fn new(
        trigger: ReferenceUpdate,
        def_grad: &[Matrix<D>],
        materials: &[Material],
        material: &[u32],
        plastic: Option<&[PlasticState]>,
    ) -> Self {
        let mut s = Self {
            trigger,
            rel: def_grad.to_vec(),
            base: None,
            hardening: None,
            pending: Vec::new(),
            updates: 0,
        };
        s.refresh_hardening(materials, material, plastic);
        s
    }

    /// Recomputes the frozen hardening scales from the plastic states (only with snow).
    pub fn refresh_hardening(
        &mut self,
        materials: &[Material],
        material: &[u32],
        plastic: Option<&[PlasticState]>,
    ) {
        let snow = materials.iter().any(
            |m| matches!(m, Material::Solid(s) if matches!(s.plasticity, Plasticity::Snow(_))),
        );
        let (true, Some(states)) = (snow, plastic) else {
            return;
        };
        let scale = self.hardening.get_or_insert_with(Vec::new);
        scale.clear();
        scale.extend(
            material
                .iter()
                .zip(states)
                .map(|(&m, st)| match &materials[m as usize] {
                    Material::Solid(s) => s.plasticity.hardening_scale(st),
                    Material::Fluid(_) => 1.0,
                }),
        );
    }

    /// G2P, plastic part: from the new `G^{n+1}` of every update, the elastic deformation
    /// gradient `F_E = Z(G^{n+1} B)`, the new base and plastic state, into `pending`. Fails at the
    /// lowest particle whose plastic flow cannot be moved into the base (`det G ≤ 0`) or whose
    /// `F_E` is not finite.
    pub fn plastic_update(
        &mut self,
        updates: &[Update<D>],
        materials: &[Material],
        material: &[u32],
        plastic: Option<&[PlasticState]>,
    ) -> Result<(), (Location, Violation, Real)> {
        let base = self.base.as_deref();
        self.pending.clear();
        updates
            .par_iter()
            .enumerate()
            .map(|(p, up)| {
                let g = up.def_grad;
                let b = base.map_or_else(Matrix::<D>::identity, |b| b[p]);
                let trial = match base {
                    Some(_) => g * b,
                    None => g,
                };
                let state = plastic.map_or_else(PlasticState::default, |s| s[p]);
                match &materials[material[p] as usize] {
                    Material::Solid(s) if !matches!(s.plasticity, Plasticity::None) => {
                        let (fe, state) = s.return_mapping(trial, state);
                        let b = Dim::<D>::inverse(&g)
                            .map_or(Matrix::<D>::from_element(Real::NAN), |gi| gi * fe);
                        (fe, b, state)
                    }
                    _ => (trial, b, state),
                }
            })
            .collect_into_vec(&mut self.pending);
        let failure = |p: usize| -> Option<(Location, Violation, Real)> {
            let (fe, b, _) = &self.pending[p];
            let at = Location::Particle(p);
            if let Some(f) = fe.iter().find(|f| !f.is_finite()) {
                return Some((at, Violation::NonFinite("elastic deformation gradient"), *f));
            }
            b.iter().any(|f| !f.is_finite()).then(|| {
                (
                    at,
                    Violation::InvertedElement,
                    Dim::<D>::det(&updates[p].def_grad),
                )
            })
        };
        match (0..self.pending.len())
            .into_par_iter()
            .filter_map(failure)
            .find_first(|_| true)
        {
            Some(f) => Err(f),
            None => Ok(()),
        }
    }

    /// After [`Self::plastic_update`]: the factor `det F_E / det F_E^trial = det B^new / det B`
    /// by which each particle's return mapping changed its elastic volume (1 for elastic
    /// particles, whose base does not change).
    pub fn plastic_volume_factors(&self) -> Vec<Real> {
        let base = self.base.as_deref();
        self.pending
            .iter()
            .enumerate()
            .map(|(p, (_, b, _))| {
                let old = base.map_or(1.0, |b| Dim::<D>::det(&b[p]));
                Dim::<D>::det(b) / old
            })
            .collect()
    }

    /// Whether the plastic flow of any material needs a base (set up before the first step).
    pub fn needs_base(materials: &[Material]) -> bool {
        materials.iter().any(Material::needs_plastic_state)
    }

    /// Number of particles with `δJ_p = |det G_p − 1| ≥ ε`, and whether they trigger an update:
    /// at least one is marked and their fraction is `≥ η`.
    pub fn marked(&self) -> (usize, bool) {
        let eps = self.trigger.epsilon;
        let n = self
            .rel
            .par_iter()
            .filter(|g| (Dim::<D>::det(g) - 1.0).abs() >= eps)
            .count();
        let fire = n > 0 && n as Real >= self.trigger.eta * self.rel.len() as Real;
        (n, fire)
    }
}
