//! The fluid domain on the background grid: the wall box, cells, linear B-spline weights of a
//! cell's corners, and the boundary quadrature points of walls and colliders (diq-mpm Eq. 30).

use mpm_core::boundary::{Collider, ColliderShape, ContactKind};
use mpm_core::{GridSpec, Real, Region, Vector};

/// A quadrature point of the wall operator `B` (Eq. 30): position, the fluid's outward unit
/// normal there, its area (m² in 3D, m in 2D) and the boundary's normal velocity `v_b·n` (m/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallPoint<const D: usize> {
    /// Position (m).
    pub x: Vector<D>,
    /// Unit normal pointing out of the fluid, into the wall (dimensionless).
    pub normal: Vector<D>,
    /// Area element (m^(D−1)).
    pub area: Real,
    /// Normal velocity of the boundary `v_b·n` (m/s).
    pub normal_velocity: Real,
}

/// A boundary quadrature point with the boundary-pressure piece it belongs to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallSample<const D: usize> {
    /// The node anchoring the boundary pressure `y` (node-centred B0 on the boundary).
    pub node: usize,
    /// Which wall (`2·axis + side`), or which piece of a collider (see [`collider_face`]).
    pub face: usize,
    /// The cell the point lies in (its `2^D` corners carry `w_c(x_q)`).
    pub cell: [usize; D],
    /// The point.
    pub point: WallPoint<D>,
}

/// The region the fluid may occupy: the box between the wall planes, which pass through node
/// layer `t` and `size − 1 − t` of each axis (`t` is the scene's wall thickness in nodes, 1
/// without walls), minus the colliders.
#[derive(Clone, Debug, PartialEq)]
pub struct Domain<const D: usize> {
    /// The grid.
    pub spec: GridSpec<D>,
    /// First and last interior node per axis.
    pub node_lo: [usize; D],
    /// Last interior node per axis.
    pub node_hi: [usize; D],
    /// Cells per axis (`size − 1`).
    pub cell_dims: [usize; D],
    /// Whether the box faces are slip walls (otherwise they are only the grid's end).
    pub walls: bool,
    /// Static colliders and colliders moving at constant velocity.
    pub colliders: Vec<Collider<D>>,
}

impl<const D: usize> Domain<D> {
    /// Number of corners of a cell, `2^D`.
    pub const CORNERS: usize = 1 << D;

    /// The domain of grid `spec` with wall planes `thickness` nodes in from each face.
    pub fn new(
        spec: GridSpec<D>,
        thickness: usize,
        walls: bool,
        colliders: Vec<Collider<D>>,
    ) -> Self {
        Self {
            spec,
            node_lo: [thickness; D],
            node_hi: std::array::from_fn(|a| spec.size[a].saturating_sub(1 + thickness)),
            cell_dims: std::array::from_fn(|a| spec.size[a].saturating_sub(1)),
            walls,
            colliders,
        }
    }

    /// Where particles may be: the box between the wall planes, which are walls only when the
    /// scene has walls.
    pub fn region(&self) -> Region<D> {
        Region {
            interior: (self.lo(), self.hi()),
            walls: self.walls.then(|| (self.lo(), self.hi())),
        }
    }

    /// What the box particles must lie in is called in messages.
    pub fn interior_name(&self) -> &'static str {
        if self.walls {
            "the box inside the walls"
        } else {
            "the grid's interior"
        }
    }

    /// Whether the box holds at least two cells per axis.
    pub fn is_valid(&self) -> bool {
        (0..D).all(|a| self.node_hi[a] >= self.node_lo[a] + 2)
    }

    /// Lower corner of the box (m).
    pub fn lo(&self) -> Vector<D> {
        Vector::<D>::from_fn(|a, _| self.spec.origin[a] + self.node_lo[a] as Real * self.spec.dx)
    }

    /// Upper corner of the box (m).
    pub fn hi(&self) -> Vector<D> {
        Vector::<D>::from_fn(|a, _| self.spec.origin[a] + self.node_hi[a] as Real * self.spec.dx)
    }

    /// Total number of cells.
    pub fn num_cells(&self) -> usize {
        self.cell_dims.iter().product()
    }

    /// Linear index of the cell with multi-index `m` (axis 0 fastest).
    pub fn cell_index(&self, m: &[usize; D]) -> usize {
        let mut c = 0;
        for a in (0..D).rev() {
            c = c * self.cell_dims[a] + m[a];
        }
        c
    }

    /// Multi-index of cell `c`.
    pub fn cell_multi(&self, mut c: usize) -> [usize; D] {
        std::array::from_fn(|a| {
            let m = c % self.cell_dims[a];
            c /= self.cell_dims[a];
            m
        })
    }

    /// The cells of the `3^D` block around cell `m` (itself included) that exist on the grid.
    pub fn neighbour_cells(&self, m: [usize; D]) -> impl Iterator<Item = [usize; D]> + '_ {
        (0..3usize.pow(D as u32)).filter_map(move |o| {
            let mut rest = o;
            let mut nm = [0usize; D];
            for a in 0..D {
                let k = m[a] as i64 + (rest % 3) as i64 - 1;
                rest /= 3;
                if k < 0 || k >= self.cell_dims[a] as i64 {
                    return None;
                }
                nm[a] = k as usize;
            }
            Some(nm)
        })
    }

    /// Whether cell `m` lies inside the wall box.
    pub fn cell_inside(&self, m: &[usize; D]) -> bool {
        (0..D).all(|a| m[a] >= self.node_lo[a] && m[a] < self.node_hi[a])
    }

    /// The interior cell holding `x` and the position's fractions within it, or `None` when `x`
    /// is outside the box or not finite. A point on an upper face belongs to the cell below.
    pub fn locate(&self, x: &Vector<D>) -> Option<([usize; D], [Real; D])> {
        let mut m = [0usize; D];
        let mut f = [0.0; D];
        for a in 0..D {
            let xh = (x[a] - self.spec.origin[a]) / self.spec.dx;
            if !(xh >= self.node_lo[a] as Real && xh <= self.node_hi[a] as Real) {
                return None;
            }
            let k = (xh.floor() as usize).min(self.node_hi[a] - 1);
            m[a] = k;
            f[a] = xh - k as Real;
        }
        Some((m, f))
    }

    /// Linear node index of corner `j` of cell `m`.
    pub fn corner_node(&self, m: &[usize; D], j: usize) -> usize {
        let mut idx = 0;
        for a in (0..D).rev() {
            idx = idx * self.spec.size[a] + m[a] + ((j >> a) & 1);
        }
        idx
    }

    /// Fraction of node `n`'s support inside the box (1/2 per axis on which the node lies on a
    /// wall plane), for the volume fraction of the position correction.
    pub fn support_fraction(&self, n: usize) -> Real {
        let mut idx = n;
        let mut frac = 1.0;
        for a in 0..D {
            let k = idx % self.spec.size[a];
            idx /= self.spec.size[a];
            if self.walls && (k == self.node_lo[a] || k == self.node_hi[a]) {
                frac *= 0.5;
            }
        }
        frac
    }

    /// The static quadrature points of the box walls, two Gauss–Legendre points per cell edge
    /// along each tangential axis (exact for the bilinear integrand of `B`). Each point comes
    /// with the wall node whose piece of wall (the node-centred B0 box on the wall plane) holds
    /// it, the face (`2·axis + side`), and the cell it lies in; sorted by node, then face.
    /// Empty without walls.
    pub fn wall_points(&self) -> Vec<WallSample<D>> {
        if !self.walls {
            return Vec::new();
        }
        let g = [0.5 - 0.5 / 3f64.sqrt(), 0.5 + 0.5 / 3f64.sqrt()];
        let dx = self.spec.dx;
        let area = (0.5 * dx).powi(D as i32 - 1);
        let mut out = Vec::new();
        for a in 0..D {
            for side in 0..2 {
                let (cell_a, plane, sign) = if side == 0 {
                    (self.node_lo[a], self.node_lo[a], -1.0)
                } else {
                    (self.node_hi[a] - 1, self.node_hi[a], 1.0)
                };
                // Every interior cell on this face, then 2^(D−1) points in it.
                let count: usize = (0..D)
                    .filter(|&b| b != a)
                    .map(|b| self.node_hi[b] - self.node_lo[b])
                    .product();
                for i in 0..count {
                    let mut rest = i;
                    let mut m = [0usize; D];
                    for b in 0..D {
                        if b == a {
                            m[b] = cell_a;
                        } else {
                            let span = self.node_hi[b] - self.node_lo[b];
                            m[b] = self.node_lo[b] + rest % span;
                            rest /= span;
                        }
                    }
                    for q in 0..(1usize << (D - 1)) {
                        let mut bit = 0;
                        let mut node = [0usize; D];
                        let x = Vector::<D>::from_fn(|b, _| {
                            let u = if b == a {
                                node[b] = plane;
                                plane as Real
                            } else {
                                let up = (q >> bit) & 1;
                                bit += 1;
                                node[b] = m[b] + up;
                                m[b] as Real + g[up]
                            };
                            self.spec.origin[b] + u * dx
                        });
                        let mut normal = Vector::<D>::zeros();
                        normal[a] = sign;
                        out.push(WallSample {
                            node: self.node_index(&node),
                            face: 2 * a + side,
                            cell: m,
                            point: WallPoint {
                                x,
                                normal,
                                area,
                                normal_velocity: 0.0,
                            },
                        });
                    }
                }
            }
        }
        out.sort_by_key(|s| (s.node, s.face));
        out
    }

    /// Linear index of node `n`.
    pub fn node_index(&self, n: &[usize; D]) -> usize {
        let mut idx = 0;
        for a in (0..D).rev() {
            idx = idx * self.spec.size[a] + n[a];
        }
        idx
    }

    /// The node nearest to `x` (the node-centred B0 box holding it).
    pub fn nearest_node(&self, x: &Vector<D>) -> usize {
        let n: [usize; D] = std::array::from_fn(|a| {
            let k = ((x[a] - self.spec.origin[a]) / self.spec.dx).round();
            (k.max(0.0) as usize).min(self.spec.size[a] - 1)
        });
        self.node_index(&n)
    }

    /// Quadrature points of the collider surfaces in cell `m` at time `t` (s): the cell is
    /// sampled at `3^D` sub-cell centres `h = Δx/3` apart, and each sample within `h/2` of a
    /// surface is projected onto it with area `h^(D−1)` (a box-smoothed surface delta of width
    /// `h`, which integrates the area of any smooth surface to first order in `h`).
    pub fn collider_points(&self, m: &[usize; D], t: Real, out: &mut Vec<WallSample<D>>) {
        if self.colliders.is_empty() {
            return;
        }
        let dx = self.spec.dx;
        let h = dx / 3.0;
        let centre = Vector::<D>::from_fn(|a, _| self.spec.origin[a] + (m[a] as Real + 0.5) * dx);
        for (ci, collider) in self.colliders.iter().enumerate() {
            let shift = collider.velocity * t;
            let (phi_c, _) = collider.shape.signed_distance(&(centre - shift));
            if phi_c > dx * (D as Real).sqrt() {
                continue;
            }
            for s in 0..3usize.pow(D as u32) {
                let mut rest = s;
                let x = Vector::<D>::from_fn(|a, _| {
                    let k = rest % 3;
                    rest /= 3;
                    self.spec.origin[a] + (m[a] as Real + (k as Real + 0.5) / 3.0) * dx
                });
                let (phi, n) = collider.shape.signed_distance(&(x - shift));
                // The band is closed up to round-off: a surface on a cell face lies exactly
                // h/2 from the sub-cell points next to it.
                if phi.abs() <= 0.5 * h * (1.0 + 1e-9) && n.norm() > 0.0 {
                    // The collider's normal points into the fluid; the fluid's points out.
                    let normal = -n;
                    let on_surface = x - n * phi;
                    out.push(WallSample {
                        node: self.nearest_node(&on_surface),
                        face: collider_face::<D>(ci, &collider.shape, &normal),
                        cell: *m,
                        point: WallPoint {
                            x: on_surface,
                            normal,
                            area: h.powi(D as i32 - 1),
                            normal_velocity: collider.velocity.dot(&normal),
                        },
                    });
                }
            }
        }
    }

    /// Moves `x` into the box (at least `margin` m inside each wall) and out of every collider
    /// (to `margin` m outside its surface) at time `t` (s).
    pub fn clamp(&self, x: &mut Vector<D>, t: Real, margin: Real) {
        for collider in &self.colliders {
            let shift = collider.velocity * t;
            let (phi, n) = collider.shape.signed_distance(&(*x - shift));
            if phi < margin && n.norm() > 0.0 {
                *x += n * (margin - phi);
            }
        }
        let (lo, hi) = (self.lo(), self.hi());
        for a in 0..D {
            x[a] = x[a].clamp(lo[a] + margin, hi[a] - margin);
        }
    }

    /// Whether every collider is a free-slip one (the only kind DIQ-MPM enforces, Eq. 25).
    pub fn colliders_are_slip(&self) -> bool {
        self.colliders
            .iter()
            .all(|c| c.contact.kind == ContactKind::Slip && c.contact.friction == 0.0)
    }
}

/// The boundary-pressure piece of a point of collider `index` of shape `shape` with outward
/// fluid normal `n`. A box has one piece per face at each node, `2D (1 + index) + 2·axis +
/// side` with the axis and sign of `n`'s largest component, as a wall corner does: with a
/// single one, a corner node's row holds only the sum of the two faces' normal velocities, and
/// water at rest around a submerged box flowed in at its corners (measured at Δx = 1/32 m:
/// 0.12 m/s after 1 s; with one row per face, 2e-8 m/s). A smooth shape (sphere, half-space)
/// has one piece per node, `2D (1 + index)`, its continuous normal's B0 piece: split by axis,
/// a sphere's nodes near 45° get two nearly parallel rows (with that split, and the surface
/// also sampled in the cells around the fluid, the pour scene's pressure CG took 3.5× the
/// iterations).
pub fn collider_face<const D: usize>(
    index: usize,
    shape: &ColliderShape<D>,
    n: &Vector<D>,
) -> usize {
    let piece = match shape {
        ColliderShape::Box { .. } => normal_class(n),
        _ => 0,
    };
    2 * D * (1 + index) + piece
}

/// `2·axis + side` of the largest component of `n` (side 1 when it is positive): which of the
/// `2D` axis directions `n` is closest to.
fn normal_class<const D: usize>(n: &Vector<D>) -> usize {
    let a = (0..D)
        .max_by(|&i, &j| n[i].abs().total_cmp(&n[j].abs()))
        .unwrap_or(0);
    2 * a + usize::from(n[a] > 0.0)
}

/// Linear B-spline weights and gradients (1/m) of the `2^D` corners of a cell at fractions `f`
/// for spacing `dx` (m); corner `j` has bit `a` set for the upper node along axis `a`.
pub fn corner_weights<const D: usize>(
    f: &[Real; D],
    dx: Real,
    w: &mut [Real],
    g: &mut [Vector<D>],
) {
    for j in 0..(1usize << D) {
        let mut weight = 1.0;
        let mut grad = Vector::<D>::zeros();
        for a in 0..D {
            let up = (j >> a) & 1 == 1;
            weight *= if up { f[a] } else { 1.0 - f[a] };
        }
        for a in 0..D {
            let mut ga = if (j >> a) & 1 == 1 { 1.0 } else { -1.0 } / dx;
            for b in 0..D {
                if b != a {
                    ga *= if (j >> b) & 1 == 1 { f[b] } else { 1.0 - f[b] };
                }
            }
            grad[a] = ga;
        }
        w[j] = weight;
        g[j] = grad;
    }
}
