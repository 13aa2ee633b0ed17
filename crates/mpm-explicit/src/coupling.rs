//! The coupling stage between phase grids (multigrid paper §4.1–4.3): drag, contact with normal
//! share β and friction δ, the buoyancy penalty and the pore-pressure term of Eq. 15. Every
//! coupling exchanges equal and opposite impulses node by node, so the total momentum of all
//! phases is unchanged (to round-off).

use crate::blocks::{Blocks, GridRef, Sums};
use crate::materials::MaterialView;
use crate::multigrid::{
    Activation, ContactCoupling, Coupling, CouplingKind, Drag, Friction, PressureBuoyancy,
};
use crate::p2g::mls_gradient;
use mpm_core::{GridNodes, GridSpec, Material, Particles, Real, Stencil, Vector};
use rayon::prelude::*;

/// What the couplings need from a phase besides its grid mass and velocity, scattered in one
/// extra pass over the phase's particles.
#[derive(Clone, Debug, Default)]
pub(crate) struct PhaseGeometry<const D: usize> {
    /// `Σ_p w_ip m_p ρ_0,p` (kg²/m^D): node rest density times node mass (Eq. 31).
    pub rest: Vec<Real>,
    /// `Σ_p m_p w_ip (x_i − x_p)` (kg·m): the unnormalised outward normal (Eq. 26).
    pub normal: Vec<Vector<D>>,
    /// `Σ_p V_p p_p M⁻¹ w_ip (x_i − x_p)` (N): the nodal pore-pressure force (Eq. 15), when needed.
    pub pressure: Vec<Vector<D>>,
}

impl<const D: usize> PhaseGeometry<D> {
    /// Bytes held (lengths, not capacities).
    pub fn bytes(&self) -> usize {
        self.rest.len() * std::mem::size_of::<Real>()
            + (self.normal.len() + self.pressure.len()) * std::mem::size_of::<Vector<D>>()
    }
}

/// Which geometry each phase needs, decided once from the couplings.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct GeometryNeeds {
    /// Normals and rest densities (contact, buoyancy penalty, permeability drag).
    pub geometry: bool,
    /// The pore-pressure force of Eq. 15 (the fluid phase of such a coupling).
    pub pressure: bool,
}

/// The geometry each of `count` phases needs for `couplings`.
pub(crate) fn geometry_needs(count: usize, couplings: &[Coupling]) -> Vec<GeometryNeeds> {
    let mut needs = vec![GeometryNeeds::default(); count];
    for c in couplings {
        let geometry = matches!(
            c.kind,
            CouplingKind::Contact(_) | CouplingKind::Drag(Drag::Permeability { .. })
        ) || c.buoyancy.is_some();
        for k in c.phases {
            needs[k as usize].geometry |= geometry;
        }
        if c.pressure_buoyancy == PressureBuoyancy::On {
            needs[c.phases[1] as usize].geometry = true;
            needs[c.phases[1] as usize].pressure = true;
        }
    }
    needs
}

/// Scatters the geometry of the particles binned in `blocks` (one phase).
pub(crate) fn scatter_geometry<const D: usize>(
    GridRef {
        spec,
        layout,
        kernel,
    }: GridRef<'_, D>,
    particles: &Particles<D>,
    materials: &MaterialView<'_>,
    blocks: &mut Blocks<D>,
    out: &mut PhaseGeometry<D>,
    pressure: bool,
) {
    let minv = kernel.mls_inertia_inv(spec.dx);
    let sums = Sums {
        mass: &mut out.rest,
        momentum: Some(&mut out.normal),
        momentum0: pressure.then_some(&mut out.pressure),
        extra: None,
    };
    blocks.scatter(
        layout,
        sums,
        |p, window, (rest_i, normal, pressure_force, _)| {
            let (xp, m) = (particles.x[p], particles.mass[p]);
            let material = materials.get(particles, p);
            let rest = m * material.density();
            let pv = match material.as_ref() {
                Material::Fluid(f) if pressure => {
                    let j = particles.jacobian_of(p);
                    f.pressure(j) * j * particles.volume0[p]
                }
                _ => 0.0,
            };
            Stencil::new(kernel, spec, &xp).for_each(|node, w, grad| {
                let d = spec.node_position(&node) - xp;
                let k = window.local(&node);
                rest_i[k] += w * rest;
                normal[k] += d * (w * m);
                if pressure {
                    pressure_force[k] += mls_gradient(minv, w, &grad, &d) * pv;
                }
            });
        },
    );
}

/// Node data of one phase that a coupling reads.
#[derive(Clone, Copy)]
struct Side<'a, const D: usize> {
    mass: &'a [Real],
    geometry: &'a PhaseGeometry<D>,
}

/// Applies `coupling` to the velocities of its two phase grids for a step of `dt` (s).
pub(crate) fn couple<const D: usize>(
    spec: &GridSpec<D>,
    coupling: &Coupling,
    grids: &mut [GridNodes<D>],
    geometry: &[PhaseGeometry<D>],
    gravity: &Vector<D>,
    dt: Real,
) {
    let [a, b] = coupling.phases.map(|k| k as usize);
    let (ga, gb) = pair_mut(grids, a, b);
    let sa = Side {
        mass: &ga.mass,
        geometry: &geometry[a],
    };
    let sb = Side {
        mass: &gb.mass,
        geometry: &geometry[b],
    };
    let node = NodeCoupling {
        coupling,
        cell_volume: spec.cell_volume(),
        gravity: *gravity,
        dt,
    };
    ga.velocity
        .par_iter_mut()
        .zip(gb.velocity.par_iter_mut())
        .enumerate()
        .for_each(|(i, (va, vb))| {
            let (ma, mb) = (sa.mass[i], sb.mass[i]);
            if ma > 0.0 && mb > 0.0 {
                node.apply(i, (ma, va, &sa), (mb, vb, &sb));
            }
        });
}

/// Two distinct elements of a slice, mutably.
fn pair_mut<T>(items: &mut [T], a: usize, b: usize) -> (&mut T, &mut T) {
    assert_ne!(a, b, "a coupling joins two distinct phases");
    if a < b {
        let (lo, hi) = items.split_at_mut(b);
        (&mut lo[a], &mut hi[0])
    } else {
        let (lo, hi) = items.split_at_mut(a);
        (&mut hi[0], &mut lo[b])
    }
}

struct NodeCoupling<'a, const D: usize> {
    coupling: &'a Coupling,
    cell_volume: Real,
    gravity: Vector<D>,
    dt: Real,
}

impl<const D: usize> NodeCoupling<'_, D> {
    /// Couples node `i`, where both phases have mass.
    fn apply(
        &self,
        i: usize,
        (ma, va, sa): (Real, &mut Vector<D>, &Side<'_, D>),
        (mb, vb, sb): (Real, &mut Vector<D>, &Side<'_, D>),
    ) {
        let dt = self.dt;
        let m = ma + mb;
        // Force on phase b (N); phase a receives the opposite.
        let mut fb = Vector::<D>::zeros();
        match self.coupling.kind {
            CouplingKind::Full => {
                let v = (*va * ma + *vb * mb) / m;
                *va = v;
                *vb = v;
            }
            CouplingKind::Drag(drag) => {
                let c = match drag {
                    Drag::Coefficient(c) => c,
                    Drag::Permeability {
                        porosity,
                        conductivity,
                    } => {
                        let rho_w = sb.geometry.rest[i] / mb;
                        porosity * porosity * rho_w * self.gravity.norm() * self.cell_volume
                            / (conductivity * ma * mb)
                    }
                };
                // Eq. 17: beyond c_max the exchange would overshoot the common velocity.
                let c = c.min(1.0 / (dt * m));
                fb = (*va - *vb) * (c * ma * mb);
            }
            CouplingKind::Contact(contact) => {
                let normal = interface_normal(&sa.geometry.normal[i], &sb.geometry.normal[i]);
                fb = contact_force(&contact, ma, mb, va, vb, normal, dt);
            }
        }
        if let Some(bp) = self.coupling.buoyancy {
            let (rho_a, rho_b) = (ma / self.cell_volume, mb / self.cell_volume);
            let (rest_a, rest_b) = (sa.geometry.rest[i] / ma, sb.geometry.rest[i] / mb);
            let f = self.gravity * (bp.strength * (rho_b * ma / rest_a).max(rho_a * mb / rest_b));
            if rest_b > rest_a {
                fb += f;
            } else if rest_a > rest_b {
                fb -= f;
            }
        }
        if self.coupling.pressure_buoyancy == PressureBuoyancy::On {
            fb -= sb.geometry.pressure[i] * (ma / m);
        }
        *vb += fb * (dt / mb);
        *va -= fb * (dt / ma);
    }
}

/// The interface normal `n_b` of Eq. 27, pointing out of phase b, or `None` where the phases'
/// normals of Eq. 26 cancel.
fn interface_normal<const D: usize>(na: &Vector<D>, nb: &Vector<D>) -> Option<Vector<D>> {
    let unit = |n: &Vector<D>| {
        let l = n.norm();
        if l > 0.0 {
            n / l
        } else {
            Vector::<D>::zeros()
        }
    };
    let n = unit(nb) - unit(na);
    let l = n.norm();
    (l > 0.0).then(|| n / l)
}

/// The contact force on phase b (Eqs. 24–30). Where the normal is undefined, `Always` applies the
/// whole collision force and `OnApproach` applies none.
fn contact_force<const D: usize>(
    contact: &ContactCoupling,
    ma: Real,
    mb: Real,
    va: &Vector<D>,
    vb: &Vector<D>,
    normal: Option<Vector<D>>,
    dt: Real,
) -> Vector<D> {
    // Eq. 24 with p = m v: (p_a m_b − p_b m_a)/((m_a + m_b) Δt).
    let f_col = (va - vb) * (ma * mb / ((ma + mb) * dt));
    let Some(n) = normal else {
        return match contact.activation {
            Activation::Always => f_col,
            Activation::OnApproach => Vector::<D>::zeros(),
        };
    };
    let approaching = (vb - va).dot(&n) > 0.0;
    if contact.activation == Activation::OnApproach && !approaching {
        return Vector::<D>::zeros();
    }
    let f_n = n * f_col.dot(&n);
    let f_t_bar = f_col - f_n;
    let f_t = match contact.friction {
        Friction::Proportional(delta) => f_t_bar * delta,
        Friction::Coulomb(delta) => {
            let (t, limit) = (f_t_bar.norm(), delta * f_n.norm());
            if t <= limit {
                f_t_bar
            } else {
                f_t_bar * (limit / t)
            }
        }
    };
    f_n * contact.normal_share + f_t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multigrid::BuoyancyPenalty;

    fn contact(beta: Real, friction: Friction, activation: Activation) -> ContactCoupling {
        ContactCoupling {
            normal_share: beta,
            friction,
            activation,
        }
    }

    #[test]
    fn full_contact_reaches_the_common_velocity_and_conserves_momentum() {
        let (ma, mb, dt) = (2.0, 0.5, 1e-3);
        let va = Vector::<2>::new(1.0, -0.5);
        let vb = Vector::<2>::new(-3.0, 2.0);
        let n = Some(Vector::<2>::new(-1.0, 0.0));
        // β = 1 with unlimited friction, always on: single-grid coupling.
        let c = contact(1.0, Friction::Coulomb(Real::INFINITY), Activation::Always);
        let f = contact_force(&c, ma, mb, &va, &vb, n, dt);
        let (va2, vb2) = (va - f * (dt / ma), vb + f * (dt / mb));
        let common = (va * ma + vb * mb) / (ma + mb);
        assert!((va2 - common).norm() < 1e-12 && (vb2 - common).norm() < 1e-12);
        assert!((va2 * ma + vb2 * mb - (va * ma + vb * mb)).norm() < 1e-12);
    }

    #[test]
    fn frictionless_contact_keeps_the_tangential_velocity() {
        let (ma, mb, dt) = (1.0, 1.0, 1e-3);
        // b moves towards a along its outward normal −x, and slides along y.
        let va = Vector::<2>::zeros();
        let vb = Vector::<2>::new(-2.0, 3.0);
        let n = Some(Vector::<2>::new(-1.0, 0.0));
        let c = contact(1.0, Friction::Coulomb(0.0), Activation::OnApproach);
        let f = contact_force(&c, ma, mb, &va, &vb, n, dt);
        let vb2 = vb + f * (dt / mb);
        let va2 = va - f * (dt / ma);
        assert!((vb2.x - va2.x).abs() < 1e-12, "normal approach stopped");
        assert_eq!(vb2.y, 3.0);
        assert_eq!(va2.y, 0.0);
        // Separating along the normal: no force on approach-only contact.
        let away = Vector::<2>::new(2.0, 3.0);
        assert_eq!(
            contact_force(&c, ma, mb, &va, &away, n, dt),
            Vector::<2>::zeros()
        );
        // Coulomb with δ: the tangential force is capped at δ|f_n|.
        let c = contact(1.0, Friction::Coulomb(0.5), Activation::OnApproach);
        let f = contact_force(&c, ma, mb, &va, &vb, n, dt);
        assert!((f.y.abs() - 0.5 * f.x.abs()).abs() < 1e-9 * f.norm());
        // β scales the normal part.
        let c = contact(0.3, Friction::Proportional(0.0), Activation::OnApproach);
        let f3 = contact_force(&c, ma, mb, &va, &vb, n, dt);
        let f1 = contact_force(
            &contact(1.0, Friction::Proportional(0.0), Activation::OnApproach),
            ma,
            mb,
            &va,
            &vb,
            n,
            dt,
        );
        assert!((f3 - f1 * 0.3).norm() < 1e-12 * f1.norm());
    }

    #[test]
    fn interface_normal_points_out_of_b() {
        let na = Vector::<2>::new(3.0, 0.0);
        let nb = Vector::<2>::new(-1.0, 0.1);
        let n = interface_normal(&na, &nb).unwrap();
        assert!(n.x < -0.99 && (n.norm() - 1.0).abs() < 1e-15);
        assert_eq!(interface_normal(&na, &(na * 2.0)), None);
    }

    #[test]
    fn node_coupling_is_equal_and_opposite() {
        let geometry = PhaseGeometry::<2> {
            rest: vec![2.0 * 1000.0],
            normal: vec![Vector::<2>::new(0.0, -1.0)],
            pressure: vec![Vector::<2>::new(0.0, 7.0)],
        };
        let geometry_b = PhaseGeometry::<2> {
            rest: vec![0.5 * 400.0],
            normal: vec![Vector::<2>::new(0.1, 1.0)],
            pressure: vec![Vector::<2>::new(0.0, 7.0)],
        };
        let kinds = [
            CouplingKind::Full,
            CouplingKind::Drag(Drag::Coefficient(10.0)),
            CouplingKind::Drag(Drag::Permeability {
                porosity: 0.4,
                conductivity: 1e-3,
            }),
            CouplingKind::Contact(contact(0.7, Friction::Coulomb(0.3), Activation::Always)),
        ];
        for kind in kinds {
            let coupling = Coupling {
                phases: [0, 1],
                kind,
                buoyancy: Some(BuoyancyPenalty { strength: 2.0 }),
                pressure_buoyancy: PressureBuoyancy::On,
            };
            let node = NodeCoupling {
                coupling: &coupling,
                cell_volume: 0.01,
                gravity: Vector::<2>::new(0.0, -9.81),
                dt: 1e-3,
            };
            let (ma, mb) = (2.0, 0.5);
            let mut va = Vector::<2>::new(0.2, -1.0);
            let mut vb = Vector::<2>::new(-0.4, 3.0);
            let before = va * ma + vb * mb;
            let sa = Side {
                mass: &[ma],
                geometry: &geometry,
            };
            let sb = Side {
                mass: &[mb],
                geometry: &geometry_b,
            };
            node.apply(0, (ma, &mut va, &sa), (mb, &mut vb, &sb));
            let after = va * ma + vb * mb;
            assert!(
                (after - before).norm() < 1e-12,
                "{kind:?}: {before} → {after}"
            );
        }
    }

    #[test]
    fn buoyancy_penalty_pushes_the_heavier_phase_down() {
        // Phase a light (rest density 400), phase b heavy (1000).
        let ga = PhaseGeometry::<2> {
            rest: vec![1.0 * 400.0],
            normal: vec![Vector::<2>::zeros()],
            pressure: vec![],
        };
        let gb = PhaseGeometry::<2> {
            rest: vec![1.0 * 1000.0],
            normal: vec![Vector::<2>::zeros()],
            pressure: vec![],
        };
        let coupling = Coupling {
            phases: [0, 1],
            kind: CouplingKind::Drag(Drag::Coefficient(0.0)),
            buoyancy: Some(BuoyancyPenalty { strength: 1.0 }),
            pressure_buoyancy: PressureBuoyancy::Off,
        };
        let node = NodeCoupling {
            coupling: &coupling,
            cell_volume: 0.01,
            gravity: Vector::<2>::new(0.0, -10.0),
            dt: 1e-3,
        };
        let (mut va, mut vb) = (Vector::<2>::zeros(), Vector::<2>::zeros());
        let sa = Side {
            mass: &[1.0],
            geometry: &ga,
        };
        let sb = Side {
            mass: &[1.0],
            geometry: &gb,
        };
        node.apply(0, (1.0, &mut va, &sa), (1.0, &mut vb, &sb));
        assert!(vb.y < 0.0 && va.y > 0.0);
        // Eq. 32: c_b max(ρ_b m_a/ρ_0a, ρ_a m_b/ρ_0b) g with ρ = m/V = 100 kg/m²:
        // max(100/400, 100/1000) = 0.25 kg, so |Δv_b| = 0.25·10·dt/m_b.
        assert!((vb.y + 0.25 * 10.0 * 1e-3).abs() < 1e-15);
    }
}
