//! The reference configuration: reference particle positions `X_p` on the initial grid, with the
//! B-spline weights `W_i(X_p)` and reference gradients `∇^X W_i(X_p)` computed once and cached
//! (diq-mpm §3.1). Because TLMPM never moves particles relative to this grid, the particle–node
//! connectivity, the lumped node masses `m_i = Σ_p W_i(X_p) m_p` and the sparsity pattern of the
//! tangent are fixed for the whole run.
//!
//! Only *active* nodes, those with positive weight for some particle, are stored; they are
//! numbered in grid order. A stencil node with zero weight (a particle on the edge of a spline's
//! support) is left out together with its gradient, which is zero there for the quadratic and
//! cubic splines; for the linear kernel this happens only for particles exactly on a grid line,
//! where the tent function has no derivative.

use crate::params::{ClampPlane, FixedRegion};
use mpm_core::{GridSpec, Kernel, Real, SetupError, Stencil, Vector};
use mpm_linalg::DofMap;
use rayon::prelude::*;

/// Marks a stencil slot without an active node.
pub(crate) const NONE: u32 = u32::MAX;

/// Cached reference-configuration data of one TLMPM body set.
#[derive(Clone, Debug)]
pub struct ReferenceConfig<const D: usize> {
    spec: GridSpec<D>,
    kernel: Kernel,
    /// Exact clamps folded into the basis (see [`ClampPlane`]).
    planes: Vec<ClampPlane>,
    slots: usize,
    positions: Vec<Vector<D>>,
    slot_node: Vec<u32>,
    slot_weight: Vec<Real>,
    slot_gradient: Vec<Vector<D>>,
    node_grid: Vec<usize>,
    node_position: Vec<Vector<D>>,
    node_mass: Vec<Real>,
    incidence_ptr: Vec<usize>,
    incidence: Vec<(u32, u32)>,
}

impl<const D: usize> ReferenceConfig<D> {
    /// Caches the stencils of particles at reference positions `positions` (m) with masses
    /// `mass` (kg) on grid `spec` with `kernel`. Every stencil must lie inside the grid.
    pub fn new(
        spec: GridSpec<D>,
        kernel: Kernel,
        planes: &[ClampPlane],
        positions: &[Vector<D>],
        mass: &[Real],
    ) -> Result<Self, SetupError> {
        if positions.len() >= NONE as usize {
            return Err(SetupError::InvalidParameter {
                name: crate::parameters::PARTICLES,
                value: positions.len() as Real,
                reason: "too many particles for 32-bit indices",
            });
        }
        let range = spec.stencil_range(kernel);
        for (p, x) in positions.iter().enumerate() {
            if !range.contains(&spec, x) {
                return Err(SetupError::outside(
                    p,
                    x,
                    &mpm_core::sampling::interior(&spec, kernel),
                    "the grid's interior",
                ));
            }
        }
        let mirrors = mirror_planes(&spec, kernel, planes, positions)?;
        let slots = kernel.support().pow(D as u32);
        let n = positions.len();
        // Pass 1: which grid nodes carry weight.
        let mut entries = Vec::with_capacity(slots);
        let mut node_of_grid = vec![NONE; spec.num_nodes()];
        for x in positions {
            stencil_entries(kernel, &spec, &mirrors, x, &mut entries);
            for &(node, w, _) in &entries {
                if let (Some(g), true) = (spec.linear_index(&node), w > 0.0) {
                    node_of_grid[g] = 0;
                }
            }
        }
        let mut node_grid = Vec::new();
        for (g, id) in node_of_grid.iter_mut().enumerate() {
            if *id == 0 {
                *id = node_grid.len() as u32;
                node_grid.push(g);
            }
        }
        if node_grid.len() >= NONE as usize {
            return Err(SetupError::InvalidParameter {
                name: crate::parameters::GRID_SIZE,
                value: node_grid.len() as Real,
                reason: "too many active nodes for 32-bit indices",
            });
        }
        // Pass 2: slots.
        let mut slot_node = Vec::with_capacity(n * slots);
        let mut slot_weight = Vec::with_capacity(n * slots);
        let mut slot_gradient = Vec::with_capacity(n * slots);
        for x in positions {
            stencil_entries(kernel, &spec, &mirrors, x, &mut entries);
            for &(node, w, g) in &entries {
                let id = spec.linear_index(&node).map_or(NONE, |i| node_of_grid[i]);
                if w > 0.0 && id != NONE {
                    slot_node.push(id);
                    slot_weight.push(w);
                    slot_gradient.push(g);
                } else {
                    slot_node.push(NONE);
                    slot_weight.push(0.0);
                    slot_gradient.push(Vector::<D>::zeros());
                }
            }
        }
        let num_nodes = node_grid.len();
        // Node → (particle, slot) incidence, particles in ascending order within each node.
        let mut incidence_ptr = vec![0usize; num_nodes + 1];
        for &i in slot_node.iter().filter(|&&i| i != NONE) {
            incidence_ptr[i as usize + 1] += 1;
        }
        for i in 0..num_nodes {
            incidence_ptr[i + 1] += incidence_ptr[i];
        }
        let mut fill = incidence_ptr.clone();
        let mut incidence = vec![(0u32, 0u32); incidence_ptr[num_nodes]];
        for p in 0..n {
            for k in 0..slots {
                let i = slot_node[p * slots + k];
                if i != NONE {
                    incidence[fill[i as usize]] = (p as u32, k as u32);
                    fill[i as usize] += 1;
                }
            }
        }
        let node_mass = (0..num_nodes)
            .map(|i| {
                incidence[incidence_ptr[i]..incidence_ptr[i + 1]]
                    .iter()
                    .map(|&(p, k)| slot_weight[p as usize * slots + k as usize] * mass[p as usize])
                    .sum()
            })
            .collect();
        let node_position = node_grid
            .iter()
            .map(|&g| spec.node_position(&spec.multi_index(g)))
            .collect();
        Ok(Self {
            spec,
            kernel,
            planes: planes.to_vec(),
            slots,
            positions: positions.to_vec(),
            slot_node,
            slot_weight,
            slot_gradient,
            node_grid,
            node_position,
            node_mass,
            incidence_ptr,
            incidence,
        })
    }

    /// The reference grid.
    pub fn spec(&self) -> &GridSpec<D> {
        &self.spec
    }

    /// The B-spline kernel.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// The exact clamps folded into the basis.
    pub fn clamp_planes(&self) -> &[ClampPlane] {
        &self.planes
    }

    /// Number of particles.
    pub fn num_particles(&self) -> usize {
        self.positions.len()
    }

    /// Number of active nodes.
    pub fn num_nodes(&self) -> usize {
        self.node_grid.len()
    }

    /// Reference particle positions `X_p` (m).
    pub fn positions(&self) -> &[Vector<D>] {
        &self.positions
    }

    /// Reference positions `X_i` of the active nodes (m).
    pub fn node_positions(&self) -> &[Vector<D>] {
        &self.node_position
    }

    /// Lumped node masses `m_i = Σ_p W_i(X_p) m_p` (kg), fixed for the run.
    pub fn node_masses(&self) -> &[Real] {
        &self.node_mass
    }

    /// Grid linear index of active node `i`.
    pub fn grid_index(&self, i: usize) -> usize {
        self.node_grid[i]
    }

    /// The cached stencil of particle `p`: `(active node, W_i(X_p), ∇^X W_i(X_p) in 1/m)` for
    /// every node with positive weight, first axis fastest.
    pub fn stencil(&self, p: usize) -> impl Iterator<Item = (usize, Real, Vector<D>)> + '_ {
        let (nodes, w, g) = self.slots(p);
        (0..self.slots)
            .filter(move |&k| nodes[k] != NONE)
            .map(move |k| (nodes[k] as usize, w[k], g[k]))
    }

    /// Slots of particle `p`: node ids (`NONE` for an empty slot), weights and gradients (1/m).
    #[inline]
    pub(crate) fn slots(&self, p: usize) -> (&[u32], &[Real], &[Vector<D>]) {
        let r = p * self.slots..(p + 1) * self.slots;
        (
            &self.slot_node[r.clone()],
            &self.slot_weight[r.clone()],
            &self.slot_gradient[r],
        )
    }

    /// `(particle, slot)` pairs touching active node `i`, particles ascending.
    #[inline]
    pub(crate) fn incidence(&self, i: usize) -> &[(u32, u32)] {
        &self.incidence[self.incidence_ptr[i]..self.incidence_ptr[i + 1]]
    }

    /// Adds per-particle forces `f_p` (N) to nodal forces as `f_i += Σ_p W_i(X_p) f_p`: a
    /// gather over each node's particles in ascending order, so the sums are deterministic.
    pub(crate) fn spread_forces(&self, forces: &[Vector<D>], nodal: &mut [Vector<D>]) {
        nodal.par_iter_mut().enumerate().for_each(|(i, fi)| {
            let mut f = Vector::<D>::zeros();
            for &(p, k) in self.incidence(i) {
                f += forces[p as usize] * self.slot(p as usize, k as usize).0;
            }
            *fi += f;
        });
    }

    /// Weight and gradient of slot `k` of particle `p`.
    #[inline]
    pub(crate) fn slot(&self, p: usize, k: usize) -> (Real, &Vector<D>) {
        let s = p * self.slots + k;
        (self.slot_weight[s], &self.slot_gradient[s])
    }
}

/// Dirichlet data on the active nodes and the numbering of the nodes that keep equations.
/// A clamp plane in grid units: the axis, the plane's node coordinate and the material's side.
#[derive(Clone, Copy, Debug)]
struct Mirror {
    axis: usize,
    plane: Real,
    above: bool,
}

/// The clamp planes in grid units, checking that each lies inside the grid on a node layer or
/// midway between two, with every particle strictly on its material side, and that two planes
/// on one axis lie at least one stencil width apart (each plane's reflection must not reach the
/// other's nodes).
fn mirror_planes<const D: usize>(
    spec: &GridSpec<D>,
    kernel: Kernel,
    planes: &[ClampPlane],
    positions: &[Vector<D>],
) -> Result<Vec<Mirror>, SetupError> {
    let mut out: Vec<Mirror> = Vec::with_capacity(planes.len());
    for c in planes {
        let bad = |reason| {
            Err(SetupError::InvalidSetting {
                setting: crate::settings::clamp_plane(c.axis, c.position),
                reason,
            })
        };
        if c.axis >= D {
            return bad(format!("axis must be below {D}"));
        }
        let plane = (c.position - spec.origin[c.axis]) / spec.dx;
        let aligned = (2.0 * plane - (2.0 * plane).round()).abs() < 1e-6;
        if !(aligned && plane >= 0.0 && plane <= (spec.size[c.axis] - 1) as Real) {
            return bad(
                "the plane must lie inside the grid, on a node layer or midway between two (see \
                 ClampPlane: elsewhere the closure is first order)"
                    .into(),
            );
        }
        let plane = (2.0 * plane).round() / 2.0;
        // Strictly on the material side: there a folded weight is positive exactly where the
        // unfolded one is, so the active-node rule (positive weight) still holds.
        let on_side = |x: &Vector<D>| {
            let d = x[c.axis] - c.position;
            if c.above {
                d > 0.0
            } else {
                d < 0.0
            }
        };
        if let Some(p) = positions.iter().position(|x| !on_side(x)) {
            return bad(format!(
                "particle {p} lies on the plane or on its clamped side (the material must lie {})",
                if c.above { "above it" } else { "below it" }
            ));
        }
        let width = kernel.support() as Real;
        if out
            .iter()
            .any(|m| m.axis == c.axis && (m.plane - plane).abs() < width)
        {
            return bad(format!(
                "another clamp plane on this axis lies closer than {width} cells"
            ));
        }
        out.push(Mirror {
            axis: c.axis,
            plane,
            above: c.above,
        });
    }
    Ok(out)
}

/// The stencil of a particle at `x` with the clamp planes folded in (`Stencil::reflect_odd`):
/// along each plane's axis every node's factor becomes `N(x − i) − N(x̄ − i)`, zero on the plane,
/// so every entry vanishes there (see [`ClampPlane`]). Entries of nodes on or beyond a plane
/// keep their slot with weight 0, which leaves them out of the active nodes.
fn stencil_entries<const D: usize>(
    kernel: Kernel,
    spec: &GridSpec<D>,
    mirrors: &[Mirror],
    x: &Vector<D>,
    entries: &mut Vec<([i64; D], Real, Vector<D>)>,
) {
    entries.clear();
    let mut stencil = Stencil::new(kernel, spec, x);
    for m in mirrors {
        let xh = (x[m.axis] - spec.origin[m.axis]) / spec.dx;
        stencil.reflect_odd(kernel, m.axis, m.plane, m.above, xh);
    }
    stencil.for_each(|node, w, g| entries.push((node, w, g)));
}

#[derive(Clone, Debug)]
pub(crate) struct Constraints<const D: usize> {
    /// Per node and component: 1 when free, 0 when prescribed.
    pub mask: Vec<Vector<D>>,
    /// Per node: prescribed velocity (m/s) of the fixed components, 0 elsewhere.
    pub velocity: Vec<Vector<D>>,
    /// The equation nodes: active nodes with at least one free component, numbered in node
    /// order.
    pub dofs: DofMap,
}

impl<const D: usize> Constraints<D> {
    /// Applies `regions` (later regions override the velocity of earlier ones).
    pub fn new(reference: &ReferenceConfig<D>, regions: &[FixedRegion<D>]) -> Self {
        let n = reference.num_nodes();
        let tol = 1e-9 * reference.spec().dx;
        let mut mask = vec![Vector::<D>::from_element(1.0); n];
        let mut velocity = vec![Vector::<D>::zeros(); n];
        for (i, x) in reference.node_positions().iter().enumerate() {
            for r in regions {
                if (0..D).all(|a| x[a] >= r.min[a] - tol && x[a] <= r.max[a] + tol) {
                    for a in (0..D).filter(|&a| r.axes[a]) {
                        mask[i][a] = 0.0;
                        velocity[i][a] = r.velocity[a];
                    }
                }
            }
        }
        let dofs = DofMap::from_predicate(n, |i| mask[i].iter().any(|&m| m > 0.0));
        Self {
            mask,
            velocity,
            dofs,
        }
    }

    /// The displacement of node `i` over a step of `dt` (s): `free` (m) on the free components,
    /// `Δt v_prescribed` on the prescribed ones.
    #[inline]
    pub fn displacement(&self, i: usize, free: Vector<D>, dt: Real) -> Vector<D> {
        let mask = &self.mask[i];
        free.component_mul(mask) + (self.velocity[i] * dt).component_mul(&mask.map(|m| 1.0 - m))
    }

    /// Whether component `a` of node `i` is free.
    #[inline]
    pub fn is_free(&self, i: usize, a: usize) -> bool {
        self.mask[i][a] > 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use mpm_core::Matrix;

    fn lattice<const D: usize>(lo: Real, hi: Real, h: Real) -> Vec<Vector<D>> {
        let n = ((hi - lo) / h).round() as usize;
        (0..n.pow(D as u32))
            .map(|k| {
                let mut r = k;
                Vector::<D>::from_fn(|_, _| {
                    let i = r % n;
                    r /= n;
                    lo + (i as Real + 0.5) * h
                })
            })
            .collect()
    }

    fn check<const D: usize>() {
        let spec = GridSpec::<D>::new(Vector::<D>::zeros(), 0.1, [12; D]);
        let x = lattice::<D>(0.3, 0.7, 0.05);
        let m = vec![2.0; x.len()];
        for kernel in [Kernel::Linear, Kernel::Quadratic, Kernel::Cubic] {
            let r = ReferenceConfig::new(spec, kernel, &[], &x, &m).unwrap();
            // Node masses add up to the particle mass.
            assert_relative_eq!(
                r.node_masses().iter().sum::<Real>(),
                2.0 * x.len() as Real,
                max_relative = 1e-13
            );
            for p in 0..x.len() {
                // Partition of unity and linear reproduction, Σ X_i ⊗ ∇W_i = I.
                let (mut w, mut g) = (0.0, Matrix::<D>::zeros());
                for (i, wi, gi) in r.stencil(p) {
                    w += wi;
                    g += r.node_positions()[i] * gi.transpose();
                }
                assert_relative_eq!(w, 1.0, epsilon = 1e-13);
                assert_relative_eq!(g, Matrix::<D>::identity(), epsilon = 1e-11);
            }
            // Incidence lists are the transpose of the stencils, particles ascending.
            let total: usize = (0..r.num_nodes()).map(|i| r.incidence(i).len()).sum();
            assert_eq!(total, (0..x.len()).map(|p| r.stencil(p).count()).sum());
            for i in 0..r.num_nodes() {
                assert!(r.incidence(i).windows(2).all(|w| w[0].0 < w[1].0));
            }
        }
        let outside = vec![Vector::<D>::from_element(0.01)];
        assert!(matches!(
            ReferenceConfig::new(spec, Kernel::Quadratic, &[], &outside, &[1.0]),
            Err(SetupError::ParticleOutsideGrid { index: 0, .. })
        ));
    }

    #[test]
    fn cached_stencils_reproduce_mass_and_linear_fields() {
        check::<2>();
        check::<3>();
    }

    #[test]
    fn constraints_number_equation_nodes() {
        let spec = GridSpec::<2>::new(Vector::<2>::zeros(), 0.1, [12; 2]);
        let x = lattice::<2>(0.3, 0.7, 0.05);
        let r =
            ReferenceConfig::new(spec, Kernel::Quadratic, &[], &x, &vec![1.0; x.len()]).unwrap();
        let mut roller = FixedRegion::clamp(Vector::<2>::new(0.0, 0.0), Vector::<2>::new(1.2, 0.3));
        roller.axes = [false, true];
        let clamp = FixedRegion::clamp(Vector::<2>::new(0.0, 0.7), Vector::<2>::new(1.2, 1.2));
        let c = Constraints::new(&r, &[roller, clamp]);
        // Quadratic stencils of particles at 0.325..0.675 reach nodes 2..=8 per axis.
        assert_eq!(r.num_nodes(), 49);
        // Rows y = 0.2, 0.3 (14 nodes) on rollers, rows y = 0.7, 0.8 (14 nodes) clamped.
        let fixed: usize = c
            .mask
            .iter()
            .map(|m| m.iter().filter(|&&x| x == 0.0).count())
            .sum();
        assert_eq!(fixed, 14 + 28);
        assert_eq!(c.dofs.len(), 35);
    }

    /// A clamp plane folds the basis so that every weight is
    /// `N_k(X) − N_k(X̄)`, `X̄` the particle's mirror image, which is zero on the plane: the
    /// plane holds exactly whatever the node values. Checked on node layers and midway between
    /// two, for the quadratic and the cubic spline, weights and gradients.
    #[test]
    fn clamp_planes_fold_the_basis_so_that_it_vanishes_on_the_plane() {
        let spec = GridSpec::<2>::new(Vector::<2>::new(-0.3, -0.3), 0.1, [14; 2]);
        for kernel in [Kernel::Quadratic, Kernel::Cubic] {
            for plane in [0.0, 0.05, -0.1, 0.15] {
                let c = ClampPlane {
                    axis: 0,
                    position: plane,
                    above: true,
                };
                // Particles from just above the plane to two cells above it.
                let x: Vec<Vector<2>> = (1..=20)
                    .map(|k| Vector::<2>::new(plane + 0.01 * k as Real, 0.437))
                    .collect();
                let r = ReferenceConfig::new(spec, kernel, &[c], &x, &vec![1.0; x.len()]).unwrap();
                for p in 0..x.len() {
                    // N_k(X) − N_k(X̄) and its gradient, d/dX N_k(X̄) = (−∂ₓN_k, ∂ᵧN_k)(X̄).
                    let mut expect = std::collections::BTreeMap::new();
                    let image = Vector::<2>::new(2.0 * plane - x[p].x, x[p].y);
                    Stencil::new(kernel, &spec, &x[p]).for_each(|node, w, g| {
                        let e = expect.entry(node).or_insert((0.0, Vector::<2>::zeros()));
                        e.0 += w;
                        e.1 += g;
                    });
                    Stencil::new(kernel, &spec, &image).for_each(|node, w, g| {
                        let e = expect.entry(node).or_insert((0.0, Vector::<2>::zeros()));
                        e.0 -= w;
                        e.1 += Vector::<2>::new(g.x, -g.y);
                    });
                    let mut seen = 0;
                    for (i, w, g) in r.stencil(p) {
                        let node = spec.multi_index(r.grid_index(i));
                        assert!(2.0 * (node[0] as Real * 0.1 - 0.3) > 2.0 * plane - 1e-12);
                        let (ew, eg) = expect[&node];
                        assert!(w > 0.0 && (w - ew).abs() < 1e-14, "{kernel:?} {plane} {p}");
                        assert!((g - eg).norm() < 1e-12, "{kernel:?} {plane} {p}");
                        seen += 1;
                    }
                    // Every node with a non-zero folded function is in the stencil.
                    let material = expect
                        .iter()
                        .filter(|(n, (w, _))| n[0] as Real * 0.1 - 0.3 > plane + 1e-12 && *w > 0.0)
                        .count();
                    assert_eq!(seen, material, "{kernel:?} {plane} {p}");
                }
            }
        }
        // A particle on the clamped side or on the plane, a plane outside the grid and two
        // planes on one axis closer than a stencil width are refused.
        let x = vec![Vector::<2>::new(0.05, 0.4)];
        let at = |position, above| ClampPlane {
            axis: 0,
            position,
            above,
        };
        for c in [
            vec![at(0.0, false)],
            vec![at(0.05, true)],
            vec![at(0.03, true)],
            vec![at(-0.5, true)],
            vec![at(0.0, true), at(0.2, false)],
        ] {
            assert!(matches!(
                ReferenceConfig::new(spec, Kernel::Quadratic, &c, &x, &[1.0]),
                Err(SetupError::InvalidSetting { .. })
            ));
        }
        let ok = [at(0.0, true), at(0.35, false)];
        assert!(ReferenceConfig::new(spec, Kernel::Quadratic, &ok, &x, &[1.0]).is_ok());
    }
}
