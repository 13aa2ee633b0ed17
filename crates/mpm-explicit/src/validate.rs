//! Set-up checks of the explicit solver: parameters in range, materials and columns present,
//! stencils inside the grid, and the multi-grid settings consistent with the materials.

use crate::multigrid::{CouplingKind, DiffusionScheme, Drag, EffectiveFraction, Friction};
use crate::parameters::{FLIP_BLEND, GRID_DX, GRID_SIZE, SOFT_WALLS_LOOKAHEAD};
use crate::params::{ExplicitParams, Transfer};
use crate::settings::{self, DISSOLUTION, MIXING, PHASES, POROUS};
use mpm_core::{GridSpec, Material, Particles, Real, SetupError};

/// Checks the set-up of [`crate::ExplicitSolver::new`].
pub(crate) fn validate<const D: usize>(
    spec: &GridSpec<D>,
    params: &ExplicitParams<D>,
    materials: &[Material],
    particles: &Particles<D>,
) -> Result<(), SetupError> {
    let invalid = |name, value, reason| {
        Err(SetupError::InvalidParameter {
            name,
            value,
            reason,
        })
    };
    if !(spec.dx > 0.0 && spec.dx.is_finite()) {
        return invalid(GRID_DX, spec.dx, "must be positive and finite");
    }
    if let Some(&n) = spec.size.iter().find(|&&n| n < params.kernel.support() + 1) {
        return invalid(GRID_SIZE, n as Real, "too few nodes for the kernel");
    }
    params.step.time_step.validate()?;
    if let Transfer::Flip { blend } = params.transfer {
        if !(0.0..=1.0).contains(&blend) {
            return invalid(FLIP_BLEND, blend, "must lie in [0, 1]");
        }
    }
    if let Some(sw) = params.soft_walls {
        if !(sw.lookahead > 0.0 && sw.margin >= 0.0) {
            return invalid(SOFT_WALLS_LOOKAHEAD, sw.lookahead, "must be positive");
        }
    }
    if let Some((name, value, reason)) = params.step.damping.invalid() {
        return invalid(name, value, reason);
    }
    if let Some((name, value, reason)) = params.step.gravity_ramp.and_then(|r| r.invalid()) {
        return invalid(name, value, reason);
    }
    let columns = particles.columns();
    for (k, m) in materials.iter().enumerate() {
        let used = particles.material.iter().any(|&i| i as usize == k);
        let missing = if !used {
            None
        } else if m.needs_deformation_gradient() && !columns.deformation_gradient {
            Some("F")
        } else if matches!(m, Material::Fluid(_)) && !columns.jacobian {
            Some("J")
        } else if m.needs_plastic_state() && !columns.plastic {
            Some("plastic")
        } else {
            None
        };
        if let Some(column) = missing {
            return Err(SetupError::MissingColumn {
                material: k,
                column,
            });
        }
    }
    validate_multigrid(params, materials, particles)?;
    let range = spec.stencil_range(params.kernel);
    for p in 0..particles.len() {
        let material = particles.material[p];
        if material as usize >= materials.len() {
            return Err(SetupError::UnknownMaterial {
                index: p,
                material,
                count: materials.len(),
            });
        }
        if !range.contains(spec, &particles.x[p]) {
            return Err(SetupError::outside(
                p,
                &particles.x[p],
                &mpm_core::sampling::interior(spec, params.kernel),
                "the grid's interior",
            ));
        }
    }
    Ok(())
}

/// Checks the phases, couplings, porous interaction, mixing and dissolution against the
/// materials and particle columns.
fn validate_multigrid<const D: usize>(
    params: &ExplicitParams<D>,
    materials: &[Material],
    particles: &Particles<D>,
) -> Result<(), SetupError> {
    let fail = |setting: &str, reason: String| {
        Err(SetupError::InvalidSetting {
            setting: setting.to_string(),
            reason,
        })
    };
    let count = params.phases.count;
    let columns = particles.columns();
    if count == 0 {
        return fail(PHASES, "there must be at least one phase".into());
    }
    if count > 1 && !columns.phase {
        return fail(
            PHASES,
            format!("{count} phases need the particle column `phase`"),
        );
    }
    if let Some(p) = (0..particles.len()).find(|&p| particles.phase_of(p) >= count) {
        return fail(
            PHASES,
            format!(
                "particle {p} is in phase {}, but only {count} exist",
                particles.phase_of(p)
            ),
        );
    }
    let nonneg = |x: Real| x >= 0.0 && x.is_finite();
    for (n, c) in params.phases.couplings.iter().enumerate() {
        let name = settings::coupling(n);
        let [a, b] = c.phases;
        if a == b || a >= count || b >= count {
            return fail(
                &name,
                format!("phases {a} and {b} must be distinct and below {count}"),
            );
        }
        let ok = match c.kind {
            CouplingKind::Full => true,
            CouplingKind::Drag(Drag::Coefficient(k)) => k >= 0.0,
            CouplingKind::Drag(Drag::Permeability {
                porosity,
                conductivity,
            }) => porosity > 0.0 && porosity <= 1.0 && conductivity > 0.0,
            CouplingKind::Contact(cc) => {
                let delta = match cc.friction {
                    Friction::Coulomb(d) | Friction::Proportional(d) => d,
                };
                (0.0..=1.0).contains(&cc.normal_share) && delta >= 0.0
            }
        };
        if !ok {
            return fail(
                &name,
                "drag coefficient, porosity (0, 1], conductivity > 0, normal share [0, 1] and \
                 friction >= 0 are required"
                    .into(),
            );
        }
        if c.buoyancy.is_some_and(|bp| !nonneg(bp.strength)) {
            return fail(&name, "the buoyancy strength c_b must be >= 0".into());
        }
    }
    if let Some(porous) = &params.porous {
        if count < 2 {
            return fail(
                POROUS,
                "porous interaction needs at least two phases".into(),
            );
        }
        if !columns.volume_fraction {
            return fail(POROUS, "needs the particle column `phi_eff`".into());
        }
        if let EffectiveFraction::Relax { rate } | EffectiveFraction::MaxRelax { rate } =
            porous.update
        {
            if !nonneg(rate) {
                return fail(POROUS, format!("relaxation rate {rate} must be >= 0"));
            }
        }
        for it in &porous.interactions {
            let Some(m) = materials.get(it.material as usize) else {
                return fail(POROUS, format!("unknown material {}", it.material));
            };
            if !it.parameter.applies_to(m) {
                return fail(
                    POROUS,
                    format!(
                        "material {} has no parameter {:?}",
                        it.material, it.parameter
                    ),
                );
            }
            if !(it.scaling.exponent > 0.0
                && it.scaling.offset.is_finite()
                && it.scaling.slope.is_finite())
            {
                return fail(
                    POROUS,
                    "scaling needs exponent > 0 and finite offset and slope".into(),
                );
            }
        }
    }
    if let Some(mix) = &params.mixing {
        for k in mix.fluids {
            if !matches!(materials.get(k as usize), Some(Material::Fluid(_))) {
                return fail(MIXING, format!("material {k} is not a fluid"));
            }
        }
        if mix.fluids[0] == mix.fluids[1] {
            return fail(MIXING, "the two fluids must differ".into());
        }
        if !columns.concentration {
            return fail(MIXING, "needs the particle column `concentration`".into());
        }
        if !nonneg(mix.diffusivity) {
            return fail(
                MIXING,
                format!("diffusivity {} must be >= 0", mix.diffusivity),
            );
        }
        if mix.scheme == DiffusionScheme::MlsDifference
            && params.kernel.mls_inertia_inv(1.0).is_none()
        {
            return fail(
                MIXING,
                "the MLS difference scheme needs a quadratic or cubic kernel".into(),
            );
        }
        let mut phases = (0..particles.len())
            .filter(|&p| mix.fluids.contains(&particles.material[p]))
            .map(|p| particles.phase_of(p));
        if let Some(first) = phases.next() {
            if phases.any(|k| k != first) {
                return fail(
                    MIXING,
                    "all particles of the two fluids must be in one phase".into(),
                );
            }
        }
    }
    if let Some(d) = &params.dissolution {
        if !matches!(materials.get(d.solid as usize), Some(Material::Solid(_))) {
            return fail(DISSOLUTION, format!("material {} is not a solid", d.solid));
        }
        if params.mixing.is_none_or(|m| m.fluids[1] != d.into) {
            return fail(
                DISSOLUTION,
                format!("material {} must be the second fluid of the mixing", d.into),
            );
        }
        if d.fluid_phase >= count || !nonneg(d.rate) {
            return fail(
                DISSOLUTION,
                "needs an existing fluid phase and a rate >= 0".into(),
            );
        }
        if !columns.concentration {
            return fail(
                DISSOLUTION,
                "needs the particle column `concentration`".into(),
            );
        }
        let fluids = params.mixing.map_or([u32::MAX; 2], |m| m.fluids);
        if let Some(p) = (0..particles.len()).find(|&p| fluids.contains(&particles.material[p])) {
            if particles.phase_of(p) != d.fluid_phase {
                return fail(
                    DISSOLUTION,
                    format!(
                        "the mixing fluids must be in the solvent phase {}",
                        d.fluid_phase
                    ),
                );
            }
        }
    }
    Ok(())
}
