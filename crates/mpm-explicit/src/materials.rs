//! The material a particle behaves as in the current step: its table entry, blended with the
//! second fluid of a miscible mixing by its concentration (§4.4), then with the porous
//! interactions of its material applied at its effective volume fraction (§4.1).

use crate::multigrid::{Mixing, Porous};
use mpm_core::material::Interaction;
use mpm_core::{Material, Particles, Real};
use std::borrow::Cow;

/// Resolves per-particle materials; borrows the table entry when nothing modifies it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MaterialView<'a> {
    /// The material table.
    pub table: &'a [Material],
    interactions: &'a [Interaction],
    mixing: Option<&'a Mixing>,
}

impl<'a> MaterialView<'a> {
    /// A view of `table` with the porous interactions and mixing of the scene, if any.
    pub fn new(
        table: &'a [Material],
        porous: Option<&'a Porous>,
        mixing: Option<&'a Mixing>,
    ) -> Self {
        Self {
            table,
            interactions: porous.map_or(&[], |p| p.interactions.as_slice()),
            mixing,
        }
    }

    /// Whether every particle behaves exactly as its table entry.
    #[inline]
    pub fn is_plain(&self) -> bool {
        self.interactions.is_empty() && self.mixing.is_none()
    }

    /// The material particle `p` behaves as.
    #[inline(always)]
    pub fn get<const D: usize>(&self, particles: &Particles<D>, p: usize) -> Cow<'a, Material> {
        let base = &self.table[particles.material[p] as usize];
        if self.is_plain() {
            Cow::Borrowed(base)
        } else {
            self.modified(particles, p, base)
        }
    }

    /// [`Self::get`] when mixing or porous interactions may change the table entry `base`.
    #[cold]
    #[inline(never)]
    fn modified<const D: usize>(
        &self,
        particles: &Particles<D>,
        p: usize,
        base: &'a Material,
    ) -> Cow<'a, Material> {
        let k = particles.material[p];
        let mut m = Cow::Borrowed(base);
        if let Some(mix) = self.mixing.filter(|mix| mix.fluids.contains(&k)) {
            if let (Material::Fluid(a), Material::Fluid(b)) = (
                &self.table[mix.fluids[0] as usize],
                &self.table[mix.fluids[1] as usize],
            ) {
                m = Cow::Owned(Material::Fluid(a.blend(b, particles.concentration_of(p))));
            }
        }
        for it in self.interactions.iter().filter(|it| it.material == k) {
            let factor = it.scaling.factor(particles.volume_fraction_of(p));
            m = Cow::Owned(m.scaled(it.parameter, factor));
        }
        m
    }

    /// Rest density (kg/m^D) of particle `p`.
    pub fn rest_density<const D: usize>(&self, particles: &Particles<D>, p: usize) -> Real {
        self.get(particles, p).density()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multigrid::{DiffusionScheme, EffectiveFraction};
    use mpm_core::material::{
        ElasticModel, FluidMaterial, Lame, Parameter, Scaling, SolidMaterial, Tait,
    };
    use mpm_core::{Columns, ParticleExtra, ParticleInit, Vector};

    #[test]
    fn view_applies_interactions_at_phi_eff_and_blends_mixtures() {
        let solid = Material::Solid(SolidMaterial {
            density: 1000.0,
            elastic: ElasticModel::FixedCorotated(Lame {
                mu: 10.0,
                lambda: 20.0,
            }),
            plasticity: Default::default(),
        });
        let thin = FluidMaterial {
            density: 1000.0,
            eos: Tait {
                bulk_modulus: 1e4,
                gamma: 7.0,
            },
            viscosity: 0.0,
        };
        let thick = FluidMaterial {
            viscosity: 4.0,
            density: 600.0,
            ..thin
        };
        let table = vec![solid, Material::Fluid(thin), Material::Fluid(thick)];
        let cols = Columns {
            volume_fraction: true,
            concentration: true,
            ..Columns::for_materials(&table)
        };
        let mut particles = Particles::<2>::new(cols);
        for (material, phi, alpha) in [(0, 0.5, 0.0), (1, 0.0, 0.25), (2, 0.0, 1.0)] {
            particles.push_with(
                ParticleInit {
                    x: Vector::<2>::zeros(),
                    v: Vector::<2>::zeros(),
                    mass: 1.0,
                    volume0: 1.0,
                    material,
                    affine: Default::default(),
                },
                ParticleExtra {
                    phase: 0,
                    volume_fraction: phi,
                    concentration: alpha,
                },
            );
        }
        let porous = Porous {
            update: EffectiveFraction::Max,
            interactions: vec![Interaction {
                material: 0,
                parameter: Parameter::YoungsModulus,
                scaling: Scaling {
                    offset: 1.0,
                    slope: -0.9,
                    exponent: 1.0,
                },
            }],
        };
        let mixing = Mixing {
            fluids: [1, 2],
            diffusivity: 0.0,
            scheme: DiffusionScheme::KernelGradient,
        };
        let view = MaterialView::new(&table, Some(&porous), Some(&mixing));
        let Material::Solid(s) = view.get(&particles, 0).into_owned() else {
            panic!("solid expected")
        };
        // E × (1 − 0.9 · 0.5) = 0.55 E: both Lamé parameters scale.
        let lame = s.elastic.lame();
        assert!((lame.mu - 5.5).abs() < 1e-12 && (lame.lambda - 11.0).abs() < 1e-12);
        let Material::Fluid(f) = view.get(&particles, 1).into_owned() else {
            panic!("fluid expected")
        };
        assert_eq!(f.viscosity, 1.0);
        assert_eq!(f.density, 900.0);
        assert_eq!(view.rest_density(&particles, 2), 600.0);
        // Without interactions or mixing the table entry is borrowed as is.
        let plain = MaterialView::new(&table, None, None);
        assert!(matches!(plain.get(&particles, 0), Cow::Borrowed(_)));
    }
}
