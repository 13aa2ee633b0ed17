//! Particle volumes from grid density estimation (multigrid paper Eq. 4):
//! `ρ_i = m_i/Δx^D`, `ρ_p = Σ_i ρ_i w_ip`, `V_p = m_p/ρ_p`.

use crate::grid::{GridSpec, NodeLayout};
use crate::kernel::{Kernel, Stencil};
use crate::math::{Real, Vector};

/// Density (kg/m^D) at `x` (m) gathered from node masses `grid_mass` (kg, in the order of
/// `layout`) with `kernel`. Nodes outside the grid or not stored contribute nothing.
pub fn density_at<const D: usize>(
    spec: &GridSpec<D>,
    kernel: Kernel,
    layout: &NodeLayout<D>,
    grid_mass: &[Real],
    x: &Vector<D>,
) -> Real {
    let mut rho = 0.0;
    Stencil::new(kernel, spec, x).for_each(|node, w, _| {
        if let Some(i) = layout.index(&node) {
            rho += w * grid_mass[i];
        }
    });
    rho / spec.cell_volume()
}

/// Node masses (kg) from particle masses (serial scatter, for set-up; solvers keep their own
/// parallel P2G), stored sparsely: the layout of the blocks the particles' stencils reach, and
/// the masses in its order.
pub fn grid_mass<const D: usize>(
    spec: &GridSpec<D>,
    kernel: Kernel,
    x: &[Vector<D>],
    mass: &[Real],
) -> (NodeLayout<D>, Vec<Real>) {
    let b = NodeLayout::<D>::BLOCK as i64;
    let mut layout = NodeLayout::default();
    layout.begin(spec);
    for xp in x {
        Stencil::new(kernel, spec, xp).for_each(|node, _, _| {
            layout.mark(node.map(|n| n.div_euclid(b)));
        });
    }
    layout.finish();
    let mut m = vec![0.0; layout.len()];
    for (xp, mp) in x.iter().zip(mass) {
        Stencil::new(kernel, spec, xp).for_each(|node, w, _| {
            if let Some(i) = layout.index(&node) {
                m[i] += w * mp;
            }
        });
    }
    (layout, m)
}

/// Initial particle volumes (m^D) by density estimation (Eq. 4).
pub fn estimate_volumes<const D: usize>(
    spec: &GridSpec<D>,
    kernel: Kernel,
    x: &[Vector<D>],
    mass: &[Real],
) -> Vec<Real> {
    let (layout, gm) = grid_mass(spec, kernel, x, mass);
    x.iter()
        .zip(mass)
        .map(|(xp, mp)| mp / density_at(spec, kernel, &layout, &gm, xp))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn uniform_lattice_recovers_lattice_volume_in_the_interior() {
        // 2 particles per cell per axis, mass ρ·V: interior particles must get V = (Δx/2)².
        let dx = 0.1;
        let spec = GridSpec::<2>::new(Vector::<2>::zeros(), dx, [21, 21]);
        let h = dx / 2.0;
        let rho = 1000.0;
        let mut x = Vec::new();
        for i in 0..24 {
            for j in 0..24 {
                x.push(Vector::<2>::new(
                    0.4 + (i as Real + 0.5) * h,
                    0.4 + (j as Real + 0.5) * h,
                ));
            }
        }
        let mass = vec![rho * h * h; x.len()];
        for kernel in [Kernel::Linear, Kernel::Quadratic, Kernel::Cubic] {
            let v = estimate_volumes(&spec, kernel, &x, &mass);
            for (xp, vp) in x.iter().zip(&v) {
                if (xp.x - 1.0).abs() < 0.3 && (xp.y - 1.0).abs() < 0.3 {
                    assert_relative_eq!(*vp, h * h, max_relative = 1e-12);
                }
            }
        }
    }
}
