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
    pub fn is_plain(&self) -> bool {
        self.interactions.is_empty() && self.mixing.is_none()
    }

    /// The material particle `p` behaves as.
    pub fn get<const D: usize>(&self, particles: &Particles<D>, p: usize) -> Cow<'a, Material> {
        let k = particles.material[p];
        let base = &self.table[k as usize];
        if self.is_plain() {
            return Cow::Borrowed(base);
        }
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
