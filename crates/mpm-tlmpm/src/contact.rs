//! Particle–particle penalty contact (diq-mpm §3.2 and §5.3, after de Vaucorbeil et al. 2020).
//!
//! A TLMPM body has no current grid, so bodies (and a body with itself) touch through pairs of
//! particles tested in the current configuration. Particle `p` has an effective radius `r_p`; a
//! pair is in contact when `δ = r_p + r_q − ‖x_q − x_p‖ ≥ 0` and the pair did not start close,
//! `‖X_q − X_p‖ > r_crit = 1.5 (r_p + r_q)` (neighbours of the same body are never in contact).
//! The force on `p` is Eq. 4,
//! `f_pq = (1/Δt²) m_p m_q/(m_p + m_q) (1 − (r_p + r_q)/‖x_pq‖) x_pq` with `x_pq = x_q − x_p`,
//! which pushes the pair apart by the whole overlap in one step. Walls and colliders are bodies
//! of infinite mass: `f_p = (m_p/Δt²)(r_p − d) n` where the signed distance `d < r_p`.
//!
//! Both are linear springs on the overlap, so the forces derive from the contact potential
//! `U_c = Σ_pairs ½ (μ_pq/Δt²) δ_pq² + Σ_(p, obstacle) ½ (m_p/Δt²) δ_p²` (J), with
//! `μ_pq = m_p m_q/(m_p + m_q)`, which the solvers add to the energy they report.
//!
//! Candidate pairs come from a cell list over the current positions
//! ([`mpm_core::neighbors::CellList`], cells of edge `2 r_max`, particles sorted by cell, stable
//! in index). Forces are gathered per particle in a fixed order,
//! so results are bitwise identical for any thread count, and `f_qp = −f_pq` exactly.

use crate::reference::ReferenceConfig;
use mpm_core::boundary::ColliderShape;
use mpm_core::neighbors::CellList;
use mpm_core::{Real, Vector};
use rayon::prelude::*;

/// How the effective contact radius of a particle is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ContactRadius {
    /// `r_p = ½ (V⁰_p)^{1/D}` (de Vaucorbeil et al.; §3.2).
    FromVolume,
    /// The same radius (m) for every particle; §5.3 uses `0.5 Δx`.
    Fixed(Real),
}

impl ContactRadius {
    /// The radius (m) of a particle of initial volume `volume0` (m^D).
    pub fn radius<const D: usize>(&self, volume0: Real) -> Real {
        match *self {
            ContactRadius::FromVolume => 0.5 * volume0.powf(1.0 / D as Real),
            ContactRadius::Fixed(r) => r,
        }
    }
}

/// An obstacle of infinite mass: a collider shape or the inside of an axis-aligned box (the
/// domain walls).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Obstacle<const D: usize> {
    /// A collider; particles are kept outside it.
    Collider(ColliderShape<D>),
    /// Domain walls: particles are kept inside `[min, max]` (m).
    Walls {
        /// Lower corner (m).
        min: Vector<D>,
        /// Upper corner (m).
        max: Vector<D>,
    },
}

impl<const D: usize> Obstacle<D> {
    /// Distance (m) from `x` to the obstacle's surface on the free side (negative when inside
    /// the obstacle) and the unit normal pointing to the free side.
    fn distance(&self, x: &Vector<D>) -> (Real, Vector<D>) {
        match self {
            Obstacle::Collider(shape) => shape.signed_distance(x),
            Obstacle::Walls { min, max } => {
                let mut best = (Real::INFINITY, Vector::<D>::zeros());
                for a in 0..D {
                    for (d, s) in [(x[a] - min[a], 1.0), (max[a] - x[a], -1.0)] {
                        if d < best.0 {
                            let mut n = Vector::<D>::zeros();
                            n[a] = s;
                            best = (d, n);
                        }
                    }
                }
                best
            }
        }
    }
}

/// The name of the penalty springs' potential among the solver's energy terms
/// ([`mpm_core::Diagnostics::other_energies`]).
pub const CONTACT_ENERGY: &str = "contact";

/// What a contact pass found.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactStats {
    /// Number of particle pairs in contact (each pair counted once).
    pub pairs: usize,
    /// Number of particle–obstacle contacts.
    pub obstacle_contacts: usize,
    /// Largest overlap `δ` of any pair or obstacle contact (m).
    pub max_overlap: Real,
    /// Contact potential `U_c` of the penalty springs at these positions and this Δt (J; see
    /// the module docs).
    pub energy: Real,
}

impl ContactStats {
    /// Whether any particle touches another body or an obstacle.
    pub fn touching(&self) -> bool {
        self.pairs > 0 || self.obstacle_contacts > 0
    }

    /// The totals of `self` and `other`.
    fn merge(self, other: Self) -> Self {
        Self {
            pairs: self.pairs + other.pairs,
            obstacle_contacts: self.obstacle_contacts + other.obstacle_contacts,
            max_overlap: self.max_overlap.max(other.max_overlap),
            energy: self.energy + other.energy,
        }
    }
}

/// The state of one particle that the contact pass reads.
#[derive(Clone, Copy, Debug)]
pub struct ContactInput<'a, const D: usize> {
    /// Current positions x_p (m).
    pub x: &'a [Vector<D>],
    /// Reference positions X_p (m).
    pub x_ref: &'a [Vector<D>],
    /// Masses m_p (kg).
    pub mass: &'a [Real],
    /// Effective radii r_p (m).
    pub radius: &'a [Real],
}

/// The solvers' contact stage: the radii, the contact pass and its per-particle forces.
#[derive(Clone, Debug)]
pub(crate) struct ContactStage<const D: usize> {
    /// Effective radius r_p of every particle (m), fixed at set-up.
    radius: Vec<Real>,
    contact: ParticleContact<D>,
    /// Per-particle contact forces f^c_p (N) of the last pass.
    forces: Vec<Vector<D>>,
}

impl<const D: usize> ContactStage<D> {
    /// Radii from `rule` and the initial volumes `volume0` (m^D).
    pub fn new(rule: ContactRadius, volume0: &[Real]) -> Self {
        Self {
            radius: volume0.iter().map(|&v| rule.radius::<D>(v)).collect(),
            contact: ParticleContact::default(),
            forces: Vec::new(),
        }
    }

    /// Contact forces of Eq. 4 from the current positions `x` (m), with reference positions
    /// `x_ref` (m) for the `r_crit` exclusion, for a step of `dt` (s), added to the external nodal
    /// forces as `f^c_i = Σ_p W_i(X_p) f^c_p` (N): a gather over each node's particles in
    /// ascending order.
    pub fn apply(
        &mut self,
        reference: &ReferenceConfig<D>,
        (x, mass): (&[Vector<D>], &[Real]),
        obstacles: &[Obstacle<D>],
        dt: Real,
        external: &mut [Vector<D>],
    ) -> ContactStats {
        let input = ContactInput {
            x,
            x_ref: reference.positions(),
            mass,
            radius: &self.radius,
        };
        let stats = self.contact.forces(&input, obstacles, dt, &mut self.forces);
        reference.spread_forces(&self.forces, external);
        stats
    }
}

impl<const D: usize> ContactStage<D> {
    /// The contact potential `U_c` (J) at positions `x` (m) of particles of masses `mass` (kg),
    /// for springs of a step of `dt` (s); a fresh contact pass that changes nothing.
    pub fn energy(
        &self,
        reference: &ReferenceConfig<D>,
        (x, mass): (&[Vector<D>], &[Real]),
        obstacles: &[Obstacle<D>],
        dt: Real,
    ) -> Real {
        let input = ContactInput {
            x,
            x_ref: reference.positions(),
            mass,
            radius: &self.radius,
        };
        ParticleContact::default()
            .forces(&input, obstacles, dt, &mut Vec::new())
            .energy
    }
}

/// Cell list and scratch, reused between steps.
#[derive(Clone, Debug, Default)]
pub struct ParticleContact<const D: usize> {
    cells: CellList<D>,
    /// Per particle: force, and its contacts (pairs with higher index, obstacle contacts, largest
    /// overlap, its share of the contact potential).
    found: Vec<(Vector<D>, ContactStats)>,
}

impl<const D: usize> ParticleContact<D> {
    /// Contact forces f_p (N) on every particle for a step of `dt` (s), into `forces`; the
    /// statistics include the contact potential `U_c` (J), each pair's half counted at either
    /// particle.
    pub fn forces(
        &mut self,
        input: &ContactInput<'_, D>,
        obstacles: &[Obstacle<D>],
        dt: Real,
        forces: &mut Vec<Vector<D>>,
    ) -> ContactStats {
        let n = input.x.len();
        let r_max = input.radius.iter().copied().fold(0.0, Real::max);
        self.cells.build(input.x, 2.0 * r_max);
        let k = 1.0 / (dt * dt);
        let Self { cells, found } = self;
        (0..n)
            .into_par_iter()
            .map(|p| {
                let (mut f, mut c) = (Vector::<D>::zeros(), ContactStats::default());
                let (xp, rp, mp) = (input.x[p], input.radius[p], input.mass[p]);
                cells.for_each_candidate(p, |q| {
                    if q == p {
                        return;
                    }
                    let reach = rp + input.radius[q];
                    let d = input.x[q] - xp;
                    let dist = d.norm();
                    if dist > reach || (input.x_ref[q] - input.x_ref[p]).norm() <= 1.5 * reach {
                        return;
                    }
                    let mq = input.mass[q];
                    let scale = if dist > 0.0 { 1.0 - reach / dist } else { 0.0 };
                    f += d * (k * mp * mq / (mp + mq) * scale);
                    let overlap = reach - dist;
                    let mu = mp * mq / (mp + mq);
                    c.max_overlap = Real::max(c.max_overlap, overlap);
                    c.pairs += usize::from(q > p);
                    c.energy += 0.25 * k * mu * overlap * overlap;
                });
                for o in obstacles {
                    let (dist, normal) = o.distance(&xp);
                    if dist < rp {
                        let overlap = rp - dist;
                        f += normal * (k * mp * overlap);
                        c.max_overlap = Real::max(c.max_overlap, overlap);
                        c.obstacle_contacts += 1;
                        c.energy += 0.5 * k * mp * overlap * overlap;
                    }
                }
                (f, c)
            })
            .collect_into_vec(found);
        forces.clear();
        forces.extend(found.iter().map(|t| t.0));
        found
            .iter()
            .fold(ContactStats::default(), |s, t| s.merge(t.1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Cloud<const D: usize> {
        x: Vec<Vector<D>>,
        x_ref: Vec<Vector<D>>,
        mass: Vec<Real>,
        radius: Vec<Real>,
    }

    impl<const D: usize> Cloud<D> {
        fn input(&self) -> ContactInput<'_, D> {
            ContactInput {
                x: &self.x,
                x_ref: &self.x_ref,
                mass: &self.mass,
                radius: &self.radius,
            }
        }
    }

    /// A pseudo-random cloud whose reference positions are far apart (all pairs eligible).
    fn cloud<const D: usize>(n: usize, seed: u64) -> Cloud<D> {
        let mut s = seed;
        let mut next = move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as Real / (1u64 << 53) as Real
        };
        let x: Vec<Vector<D>> = (0..n)
            .map(|_| Vector::<D>::from_fn(|_, _| next()))
            .collect();
        let x_ref = (0..n)
            .map(|p| Vector::<D>::from_element(10.0 * p as Real))
            .collect();
        let mass = (0..n).map(|_| 0.5 + next()).collect();
        let radius = (0..n).map(|_| 0.03 + 0.04 * next()).collect();
        Cloud {
            x,
            x_ref,
            mass,
            radius,
        }
    }

    fn brute_force<const D: usize>(c: &Cloud<D>, dt: Real) -> Vec<Vector<D>> {
        let n = c.x.len();
        (0..n)
            .map(|p| {
                let mut f = Vector::<D>::zeros();
                for q in 0..n {
                    let reach = c.radius[p] + c.radius[q];
                    let d = c.x[q] - c.x[p];
                    if q != p && d.norm() <= reach && (c.x_ref[q] - c.x_ref[p]).norm() > 1.5 * reach
                    {
                        let mu = c.mass[p] * c.mass[q] / (c.mass[p] + c.mass[q]);
                        f += d * (mu / (dt * dt) * (1.0 - reach / d.norm()));
                    }
                }
                f
            })
            .collect()
    }

    fn matches_brute_force_and_conserves_momentum<const D: usize>() {
        let c = cloud::<D>(400, 7);
        let dt = 1e-3;
        let mut contact = ParticleContact::<D>::default();
        let mut f = Vec::new();
        let stats = contact.forces(&c.input(), &[], dt, &mut f);
        let reference = brute_force(&c, dt);
        assert!(stats.pairs > 10, "the cloud has contacts: {}", stats.pairs);
        let scale = reference.iter().map(|f| f.norm()).fold(0.0, Real::max);
        for (a, b) in f.iter().zip(&reference) {
            assert!((a - b).norm() <= 1e-12 * scale);
        }
        let total: Vector<D> = f.iter().sum();
        assert!(total.norm() <= 1e-12 * scale, "Σ f = {}", total.norm());
    }

    #[test]
    fn cell_list_matches_all_pairs_and_forces_balance() {
        matches_brute_force_and_conserves_momentum::<2>();
        matches_brute_force_and_conserves_momentum::<3>();
    }

    #[test]
    fn eq4_separates_an_overlapping_pair_in_one_step() {
        let (dt, r) = (1e-3, 0.1);
        let c = Cloud::<2> {
            x: vec![Vector::<2>::new(0.0, 0.0), Vector::<2>::new(0.15, 0.0)],
            x_ref: vec![Vector::<2>::new(0.0, 0.0), Vector::<2>::new(5.0, 0.0)],
            mass: vec![1.0, 3.0],
            radius: vec![r, r],
        };
        let mut f = Vec::new();
        let stats = ParticleContact::default().forces(&c.input(), &[], dt, &mut f);
        assert_eq!(stats.pairs, 1);
        assert!((stats.max_overlap - 0.05).abs() < 1e-15);
        assert_eq!(f[0], -f[1]);
        // Applied for one step, the impulses close the 0.05 m overlap exactly:
        // Δx_rel = dt² (f_1/m_1 − f_0/m_0) = 0.05.
        let gap_change = dt * dt * (f[1].x / 3.0 - f[0].x / 1.0);
        assert!((gap_change - 0.05).abs() < 1e-12, "{gap_change}");
        // The same pair that starts close (same body) is never in contact.
        let same_body = Cloud {
            x_ref: c.x.clone(),
            ..c
        };
        let stats = ParticleContact::default().forces(&same_body.input(), &[], dt, &mut f);
        assert_eq!(stats.pairs, 0);
        assert!(f.iter().all(|f| f.norm() == 0.0));
    }

    #[test]
    fn contact_potential_of_a_pair() {
        let (dt, r) = (1e-3, 0.1);
        // Pair: overlap δ = 0.2 − 0.15 = 0.05 m, μ = 1·3/(1 + 3) = 0.75 kg:
        // U = ½ μ δ²/dt² = ½ · 0.75 · 0.0025 / 1e-6 = 937.5 J.
        let mut c = Cloud::<2> {
            x: vec![Vector::<2>::new(0.0, 0.0), Vector::<2>::new(0.15, 0.0)],
            x_ref: vec![Vector::<2>::new(0.0, 0.0), Vector::<2>::new(5.0, 0.0)],
            mass: vec![1.0, 3.0],
            radius: vec![r, r],
        };
        let mut f = Vec::new();
        let stats = ParticleContact::default().forces(&c.input(), &[], dt, &mut f);
        assert!((stats.energy - 937.5).abs() < 1e-9, "{}", stats.energy);
        // The Eq. 4 force is −∂U/∂x_p: a central difference of U along x_1.
        let h = 1e-7;
        let mut energy_at = |x1: Real| {
            c.x[1].x = x1;
            ParticleContact::default()
                .forces(&c.input(), &[], dt, &mut Vec::new())
                .energy
        };
        let slope = (energy_at(0.15 + h) - energy_at(0.15 - h)) / (2.0 * h);
        assert!(
            (slope + f[1].x).abs() < 1e-6 * f[1].x.abs(),
            "{slope} vs {}",
            f[1].x
        );
    }

    #[test]
    fn obstacles_push_particles_back_to_the_free_side() {
        let dt = 1e-3;
        let c = Cloud::<2> {
            x: vec![Vector::<2>::new(0.02, 0.5), Vector::<2>::new(0.5, 0.5)],
            x_ref: vec![Vector::<2>::new(0.0, 0.0), Vector::<2>::new(9.0, 0.0)],
            mass: vec![2.0, 2.0],
            radius: vec![0.05, 0.05],
        };
        let walls = Obstacle::Walls {
            min: Vector::<2>::zeros(),
            max: Vector::<2>::new(1.0, 1.0),
        };
        let ball = Obstacle::Collider(ColliderShape::Sphere {
            center: Vector::<2>::new(0.5, 0.42),
            radius: 0.05,
        });
        let mut f = Vec::new();
        let stats = ParticleContact::default().forces(&c.input(), &[walls, ball], dt, &mut f);
        assert_eq!(stats.obstacle_contacts, 2);
        // Contact potential: ½ · 2 · (0.03² + 0.02²)/dt² = 1300 J.
        assert!((stats.energy - 1300.0).abs() < 1e-6, "{}", stats.energy);
        // Wall: overlap 0.03 m, force m·0.03/dt² along +x.
        assert!((f[0].x - 2.0 * 0.03 / (dt * dt)).abs() < 1e-9 && f[0].y == 0.0);
        // Sphere below: overlap 0.05 + 0.05 − 0.08 = 0.02 m, pushed up.
        assert!((f[1].y - 2.0 * 0.02 / (dt * dt)).abs() < 1e-6 && f[1].x.abs() < 1e-9);
    }
}
