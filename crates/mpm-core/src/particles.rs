//! Structure-of-arrays particle storage.
//!
//! Every particle has position, velocity, mass, initial volume, material index and the affine
//! velocity matrix `C` (the APIC/MLS velocity gradient, also used by viscous fluids). The other
//! columns exist only when some material in the scene needs them (DESIGN §3 and §5):
//! the deformation gradient for solids, `J = det F` for fluids, the plastic state for plastic
//! solids; and, for multi-grid scenes (multigrid paper §4), the phase index, the effective volume
//! fraction φ_eff and the concentration.

use crate::material::{Material, PlasticState};
use crate::math::{Matrix, Real, Vector};
use serde::{Deserialize, Serialize};

/// Which optional particle columns exist.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Columns {
    /// Full deformation gradient F (solids).
    pub deformation_gradient: bool,
    /// Volume ratio J = det F only (fluids).
    pub jacobian: bool,
    /// Plastic state (snow, sand).
    pub plastic: bool,
    /// Phase index: which background grid a particle belongs to (multi-grid scenes only).
    #[serde(default)]
    pub phase: bool,
    /// Effective volume fraction φ_eff (porous interaction, multigrid paper Eqs. 21, 22, 36).
    #[serde(default)]
    pub volume_fraction: bool,
    /// Concentration α (miscible mixing, Eqs. 33–35) or dissolution progress (§4.5).
    #[serde(default)]
    pub concentration: bool,
}

impl Columns {
    /// The columns the given materials need.
    pub fn for_materials(materials: &[Material]) -> Self {
        Self {
            deformation_gradient: materials.iter().any(Material::needs_deformation_gradient),
            jacobian: materials.iter().any(|m| matches!(m, Material::Fluid(_))),
            plastic: materials.iter().any(Material::needs_plastic_state),
            ..Self::default()
        }
    }

    /// Names of the columns that exist, always-present columns first.
    pub fn names(&self) -> Vec<&'static str> {
        let mut n = vec!["x", "v", "mass", "volume0", "material", "affine"];
        if self.deformation_gradient {
            n.push("F");
        }
        if self.jacobian {
            n.push("J");
        }
        if self.plastic {
            n.push("plastic");
        }
        if self.phase {
            n.push("phase");
        }
        if self.volume_fraction {
            n.push("phi_eff");
        }
        if self.concentration {
            n.push("concentration");
        }
        n
    }
}

/// One particle, as handed to [`Particles::push`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleInit<const D: usize> {
    /// Position (m).
    pub x: Vector<D>,
    /// Velocity (m/s).
    pub v: Vector<D>,
    /// Mass (kg).
    pub mass: Real,
    /// Initial volume (m^D).
    pub volume0: Real,
    /// Index into the simulation's material table.
    pub material: u32,
    /// Initial affine velocity field C (1/s), e.g. the gradient of an initial rotation.
    pub affine: Matrix<D>,
}

/// The optional multi-grid state of one particle, as handed to [`Particles::push_with`]. Values
/// for columns that do not exist are ignored.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ParticleExtra {
    /// Phase (grid) index.
    pub phase: u32,
    /// Initial effective volume fraction φ_eff ∈ [0, 1] (dimensionless).
    pub volume_fraction: Real,
    /// Initial concentration α ∈ [0, 1] (dimensionless).
    pub concentration: Real,
}

/// Particle storage, one `Vec` per field.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Particles<const D: usize> {
    /// Positions (m).
    pub x: Vec<Vector<D>>,
    /// Velocities (m/s).
    pub v: Vec<Vector<D>>,
    /// Masses (kg).
    pub mass: Vec<Real>,
    /// Initial volumes V⁰ (m^D).
    pub volume0: Vec<Real>,
    /// Material indices.
    pub material: Vec<u32>,
    /// Affine velocity matrices C ≈ ∇v (1/s).
    pub affine: Vec<Matrix<D>>,
    /// Elastic deformation gradients F_E (dimensionless), if any material is solid.
    pub def_grad: Option<Vec<Matrix<D>>>,
    /// Volume ratios J (dimensionless), if any material is a fluid.
    pub jacobian: Option<Vec<Real>>,
    /// Plastic states, if any material is plastic.
    pub plastic: Option<Vec<PlasticState>>,
    /// Phase indices, if the scene has more than one phase.
    pub phase: Option<Vec<u32>>,
    /// Effective volume fractions φ_eff (dimensionless), if porous interaction is on.
    pub volume_fraction: Option<Vec<Real>>,
    /// Concentrations α (dimensionless), if mixing or dissolution is on.
    pub concentration: Option<Vec<Real>>,
}

impl<const D: usize> Particles<D> {
    /// Empty storage with the given optional columns.
    pub fn new(columns: Columns) -> Self {
        Self {
            def_grad: columns.deformation_gradient.then(Vec::new),
            jacobian: columns.jacobian.then(Vec::new),
            plastic: columns.plastic.then(Vec::new),
            phase: columns.phase.then(Vec::new),
            volume_fraction: columns.volume_fraction.then(Vec::new),
            concentration: columns.concentration.then(Vec::new),
            ..Self::default()
        }
    }

    /// The optional columns that exist.
    pub fn columns(&self) -> Columns {
        Columns {
            deformation_gradient: self.def_grad.is_some(),
            jacobian: self.jacobian.is_some(),
            plastic: self.plastic.is_some(),
            phase: self.phase.is_some(),
            volume_fraction: self.volume_fraction.is_some(),
            concentration: self.concentration.is_some(),
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Appends a particle in its undeformed, virgin state (F = I, J = 1, default plastic state),
    /// in phase 0 with zero φ_eff and concentration.
    pub fn push(&mut self, p: ParticleInit<D>) {
        self.push_with(p, ParticleExtra::default());
    }

    /// Appends a particle in its undeformed, virgin state with the given multi-grid state.
    pub fn push_with(&mut self, p: ParticleInit<D>, extra: ParticleExtra) {
        self.x.push(p.x);
        self.v.push(p.v);
        self.mass.push(p.mass);
        self.volume0.push(p.volume0);
        self.material.push(p.material);
        self.affine.push(p.affine);
        if let Some(f) = &mut self.def_grad {
            f.push(Matrix::<D>::identity());
        }
        if let Some(j) = &mut self.jacobian {
            j.push(1.0);
        }
        if let Some(s) = &mut self.plastic {
            s.push(PlasticState::default());
        }
        if let Some(k) = &mut self.phase {
            k.push(extra.phase);
        }
        if let Some(f) = &mut self.volume_fraction {
            f.push(extra.volume_fraction);
        }
        if let Some(c) = &mut self.concentration {
            c.push(extra.concentration);
        }
    }

    /// The particles `index` (in that order) with every column, e.g. to split one set between
    /// two solvers.
    pub fn select(&self, index: &[usize]) -> Self {
        fn pick<T: Copy>(v: &[T], index: &[usize]) -> Vec<T> {
            index.iter().map(|&p| v[p]).collect()
        }
        let opt = |v: &Option<Vec<Real>>| v.as_deref().map(|v| pick(v, index));
        Self {
            x: pick(&self.x, index),
            v: pick(&self.v, index),
            mass: pick(&self.mass, index),
            volume0: pick(&self.volume0, index),
            material: pick(&self.material, index),
            affine: pick(&self.affine, index),
            def_grad: self.def_grad.as_deref().map(|f| pick(f, index)),
            jacobian: opt(&self.jacobian),
            plastic: self.plastic.as_deref().map(|s| pick(s, index)),
            phase: self.phase.as_deref().map(|k| pick(k, index)),
            volume_fraction: opt(&self.volume_fraction),
            concentration: opt(&self.concentration),
        }
    }

    /// Appends the particles of `other`, which must have the same columns (panics otherwise),
    /// after this set's: e.g. the halo copies a process receives from its peers.
    pub fn append(&mut self, other: &Self) {
        fn extend<T: Copy>(to: &mut Option<Vec<T>>, from: &Option<Vec<T>>) {
            match (to, from) {
                (Some(t), Some(f)) => t.extend_from_slice(f),
                (None, None) => {}
                _ => panic!("Particles::append: the two sets have different columns"),
            }
        }
        self.x.extend_from_slice(&other.x);
        self.v.extend_from_slice(&other.v);
        self.mass.extend_from_slice(&other.mass);
        self.volume0.extend_from_slice(&other.volume0);
        self.material.extend_from_slice(&other.material);
        self.affine.extend_from_slice(&other.affine);
        extend(&mut self.def_grad, &other.def_grad);
        extend(&mut self.jacobian, &other.jacobian);
        extend(&mut self.plastic, &other.plastic);
        extend(&mut self.phase, &other.phase);
        extend(&mut self.volume_fraction, &other.volume_fraction);
        extend(&mut self.concentration, &other.concentration);
    }

    /// Keeps the particles `p` with `keep[p]`, in order (in place; `keep` has one entry per
    /// particle).
    pub fn retain(&mut self, keep: &[bool]) {
        fn run<T>(v: &mut Vec<T>, keep: &[bool]) {
            let mut k = keep.iter();
            v.retain(|_| *k.next().expect("one flag per particle"));
        }
        fn opt<T>(v: &mut Option<Vec<T>>, keep: &[bool]) {
            if let Some(v) = v {
                run(v, keep);
            }
        }
        assert_eq!(keep.len(), self.len(), "one flag per particle");
        run(&mut self.x, keep);
        run(&mut self.v, keep);
        run(&mut self.mass, keep);
        run(&mut self.volume0, keep);
        run(&mut self.material, keep);
        run(&mut self.affine, keep);
        opt(&mut self.def_grad, keep);
        opt(&mut self.jacobian, keep);
        opt(&mut self.plastic, keep);
        opt(&mut self.phase, keep);
        opt(&mut self.volume_fraction, keep);
        opt(&mut self.concentration, keep);
    }

    /// Keeps the first `n` particles (all of them when there are fewer).
    pub fn truncate(&mut self, n: usize) {
        fn cut<T>(c: &mut Option<Vec<T>>, n: usize) {
            if let Some(c) = c {
                c.truncate(n);
            }
        }
        self.x.truncate(n);
        self.v.truncate(n);
        self.mass.truncate(n);
        self.volume0.truncate(n);
        self.material.truncate(n);
        self.affine.truncate(n);
        cut(&mut self.def_grad, n);
        cut(&mut self.jacobian, n);
        cut(&mut self.plastic, n);
        cut(&mut self.phase, n);
        cut(&mut self.volume_fraction, n);
        cut(&mut self.concentration, n);
    }

    /// Phase of particle `p` (0 when the column does not exist).
    #[inline]
    pub fn phase_of(&self, p: usize) -> u32 {
        self.phase.as_ref().map_or(0, |k| k[p])
    }

    /// Effective volume fraction of particle `p` (0 when the column does not exist).
    #[inline]
    pub fn volume_fraction_of(&self, p: usize) -> Real {
        self.volume_fraction.as_ref().map_or(0.0, |f| f[p])
    }

    /// Concentration of particle `p` (0 when the column does not exist).
    #[inline]
    pub fn concentration_of(&self, p: usize) -> Real {
        self.concentration.as_ref().map_or(0.0, |c| c[p])
    }

    /// Deformation gradient of particle `p` (identity when the column does not exist).
    #[inline]
    pub fn def_grad_of(&self, p: usize) -> Matrix<D> {
        self.def_grad
            .as_ref()
            .map_or(Matrix::<D>::identity(), |f| f[p])
    }

    /// Volume ratio J of particle `p` from the `J` column (1 when the column does not exist).
    #[inline]
    pub fn jacobian_of(&self, p: usize) -> Real {
        self.jacobian.as_ref().map_or(1.0, |j| j[p])
    }

    /// Plastic state of particle `p` (virgin when the column does not exist).
    #[inline]
    pub fn plastic_of(&self, p: usize) -> PlasticState {
        self.plastic
            .as_ref()
            .map_or(PlasticState::default(), |s| s[p])
    }

    /// Bytes of particle storage per particle for the columns that exist.
    pub fn bytes_per_particle(&self) -> usize {
        let r = std::mem::size_of::<Real>();
        let mut b = 2 * D * r + 2 * r + std::mem::size_of::<u32>() + D * D * r;
        let c = self.columns();
        if c.deformation_gradient {
            b += D * D * r;
        }
        if c.jacobian {
            b += r;
        }
        if c.plastic {
            b += std::mem::size_of::<PlasticState>();
        }
        if c.phase {
            b += std::mem::size_of::<u32>();
        }
        b += r * (usize::from(c.volume_fraction) + usize::from(c.concentration));
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Particles<2> {
        let mut ps = Particles::new(Columns {
            deformation_gradient: true,
            jacobian: true,
            phase: true,
            ..Columns::default()
        });
        for k in 0..5 {
            let init = ParticleInit {
                x: Vector::<2>::new(k as Real, 0.5),
                v: Vector::<2>::new(0.0, -(k as Real)),
                mass: 1.0 + k as Real,
                volume0: 0.25,
                material: k % 2,
                affine: Matrix::<2>::identity() * k as Real,
            };
            let extra = ParticleExtra {
                phase: k % 2,
                ..ParticleExtra::default()
            };
            ps.push_with(init, extra);
        }
        ps
    }

    #[test]
    fn truncate_then_append_restores_the_set() {
        let all = sample();
        let mut head = all.clone();
        head.truncate(2);
        assert_eq!(head.len(), 2);
        assert_eq!(head.phase.as_ref().map(Vec::len), Some(2));
        head.append(&all.select(&[2, 3, 4]));
        assert_eq!(head, all);
        let mut odd = all.clone();
        odd.retain(&[false, true, false, true, false]);
        assert_eq!(odd, all.select(&[1, 3]));
        assert_eq!(odd.phase, Some(vec![1, 1]));
    }

    #[test]
    #[should_panic(expected = "different columns")]
    fn append_refuses_other_columns() {
        let mut a = sample();
        a.append(&Particles::new(Columns::default()));
    }
}
