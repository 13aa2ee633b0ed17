//! Mirrored ghost layers at domain walls ([`WallTreatment::Mirror`]).
//!
//! **Why.** With the classic treatment every node of the wall layers gets the contact rule. A
//! quadratic or cubic B-spline of a node just inside the wall is not zero on the wall plane, so the
//! wall's reaction, which acts on every basis function that reaches the plane, is missing from
//! those nodes: the discrete equilibrium next to a wall is inconsistent. In the CB-Geo hydrostatic
//! column the mean pressure of the bottom cell layer was 9–10 % off at every Δx, and the error did
//! not shrink.
//!
//! **What.** The wall plane is the innermost wall node layer (`thickness − 1` nodes from the face).
//! The wall layers beyond it are ghosts: node `w − k` is the mirror image of node `w + k`. Each
//! velocity component is extended across the plane evenly or oddly:
//! - slip (frictionless): the normal component odd, the tangential components even, so the normal
//!   velocity vanishes on the plane and the tangential motion is free;
//! - sticky: every component odd, so the velocity vanishes on the plane.
//!
//! The grid velocity is then `Σ_k v_k φ_k` with the *boundary-modified* basis
//! `φ_k = N_k ± N_{2w−k}` per component, which satisfies the wall condition on the plane itself
//! rather than at the nodes. Galerkin with that basis is what this module does to the grid:
//! - after P2G, [`MirrorWalls::fold`] adds each ghost node's mass and momentum into its mirror node,
//!   the momentum reflected (`R = diag(±1)`), so the mirror node receives the modified basis's
//!   internal force `f_k ± f_{2w−k}`. Gravity enters the grid update as `m g`; the modified basis's
//!   body force on the folded mass is `R (m g)`, so the fold adds `Δt m (R g − g)` to the momentum
//!   to make the later `m g` right. The ghosts are then emptied, so grid totals still equal the
//!   particles' totals;
//! - after the boundaries, [`MirrorWalls::fill`] sets each ghost velocity to the reflected
//!   velocity of its mirror node, which G2P reads.
//!
//! The node on the plane keeps its contact rule (its odd components are zero, its even components
//! are its own). Faces are folded one after another, axis by axis, so corner ghosts reach their
//! diagonal mirror with both reflections. Separating contact and friction have no reflection and
//! keep the classic treatment (a setup error names them).

use crate::boundary::{ContactKind, DomainWalls};
use crate::grid::{GridSpec, NodeLayout};
use crate::math::{Real, Vector};
use serde::{Deserialize, Serialize};

/// How domain walls act on the grid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WallTreatment {
    /// Every node of the wall layers gets the contact rule (the classic MPM wall).
    #[default]
    Nodes,
    /// The innermost wall layer is the wall plane and the layers beyond it are mirrored ghosts,
    /// consistent with the B-spline transfers (see the module docs). Slip walls without friction
    /// and sticky walls only.
    Mirror,
}

/// One wall face: the axis, the wall plane's node index along it and the side of the ghosts.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Face {
    axis: usize,
    /// Node index of the wall plane along `axis`.
    plane: usize,
    /// Ghost layers (nodes beyond the plane).
    ghosts: usize,
    /// Whether the ghosts lie below the plane (the low face).
    low: bool,
}

/// The mirrored ghost layers of a grid's domain walls (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct MirrorWalls<const D: usize> {
    faces: Vec<Face>,
    size: [usize; D],
    /// Component signs of the reflection across a wall normal to each axis.
    signs: [Vector<D>; D],
}

impl<const D: usize> MirrorWalls<D> {
    /// The ghost layers of `walls` on `spec`, `Ok(None)` when the walls use the classic
    /// treatment. Errors (a sentence) when the contact has no reflection (separating, or with
    /// friction) or the grid is too small for the ghosts' mirrors to lie inside it.
    pub fn new(spec: &GridSpec<D>, walls: &DomainWalls) -> Result<Option<Self>, String> {
        if walls.treatment == WallTreatment::Nodes {
            return Ok(None);
        }
        let odd_tangent = match walls.contact.kind {
            _ if walls.contact.friction != 0.0 => {
                return Err("mirrored walls need friction = 0".into());
            }
            ContactKind::Slip => false,
            ContactKind::Sticky => true,
            ContactKind::Separate => {
                return Err("mirrored walls need contact \"slip\" or \"sticky\"".into());
            }
        };
        let t = walls.thickness;
        if t == 0 {
            return Err("mirrored walls need thickness ≥ 1".into());
        }
        let mut faces = Vec::new();
        for (axis, &n) in spec.size.iter().enumerate() {
            // The mirrors of the ghosts (up to 2(t − 1) from the face) must lie between the two
            // planes.
            if n < 4 * t {
                return Err(format!(
                    "mirrored walls of thickness {t} need at least {} nodes along axis {axis} \
                     (the grid has {n})",
                    4 * t
                ));
            }
            faces.push(Face {
                axis,
                plane: t - 1,
                ghosts: t - 1,
                low: true,
            });
            faces.push(Face {
                axis,
                plane: n - t,
                ghosts: t - 1,
                low: false,
            });
        }
        let signs = std::array::from_fn(|a| {
            Vector::<D>::from_fn(|c, _| if c == a || odd_tangent { -1.0 } else { 1.0 })
        });
        Ok(Some(Self {
            faces,
            size: spec.size,
            signs,
        }))
    }

    /// Marks in `layout` the blocks holding the mirrors of the ghost nodes of its blocks, face
    /// by face in the fold's order (a corner ghost's mirror across one face is a ghost of a
    /// later face, whose mirror is then marked too). Call after every other block is marked and
    /// before [`NodeLayout::finish`].
    pub fn mark(&self, layout: &mut NodeLayout<D>) {
        let b = NodeLayout::<D>::BLOCK;
        for face in self.faces.iter().filter(|f| f.ghosts > 0) {
            let a = face.axis;
            let (ghosts, mirrors) = if face.low {
                (
                    face.plane - face.ghosts..face.plane,
                    face.plane + 1..face.plane + face.ghosts + 1,
                )
            } else {
                (
                    face.plane + 1..face.plane + face.ghosts + 1,
                    face.plane - face.ghosts..face.plane,
                )
            };
            let ghost_blocks = ghosts.start / b..=(ghosts.end - 1) / b;
            let mirror_blocks = mirrors.start / b..=(mirrors.end - 1) / b;
            for i in 0..layout.active().len() {
                let c = layout.block_coords(layout.active()[i] as usize);
                if ghost_blocks.contains(&(c[a] as usize)) {
                    for m in mirror_blocks.clone() {
                        let mut to = c;
                        to[a] = m as i64;
                        layout.mark(to);
                    }
                }
            }
        }
    }

    /// Calls `f(ghost, mirror, sign)` (storage indices of `layout`) for every stored ghost node
    /// of every face, face by face in order.
    fn for_each_pair(&self, layout: &NodeLayout<D>, f: impl FnMut(usize, usize, &Vector<D>)) {
        self.for_each_layer(layout, 1, f);
    }

    /// Calls `f(ghost, mirror, sign)` for the stored nodes of the layers `first..=ghosts`
    /// beyond each face's plane, face by face in order; layer 0 is the plane itself
    /// (`ghost == mirror`). Within a face the pairs are disjoint, so their order does not
    /// change any sum.
    fn for_each_layer(
        &self,
        layout: &NodeLayout<D>,
        first: usize,
        mut f: impl FnMut(usize, usize, &Vector<D>),
    ) {
        let b = NodeLayout::<D>::BLOCK;
        let nodes = NodeLayout::<D>::BLOCK_NODES;
        for face in &self.faces {
            let a = face.axis;
            let stride = b.pow(a as u32);
            for k in first..=face.ghosts {
                let (ghost, mirror) = if face.low {
                    (face.plane - k, face.plane + k)
                } else {
                    (face.plane + k, face.plane - k)
                };
                for s in 0..layout.active().len() {
                    let origin = layout.slot_origin(s);
                    if origin[a] as usize != ghost - ghost % b {
                        continue;
                    }
                    for local in (0..nodes).filter(|l| (l / stride) % b == ghost % b) {
                        let g = s * nodes + local;
                        let mut node = layout.node(g);
                        if (0..D).any(|c| node[c] as usize >= self.size[c]) {
                            continue;
                        }
                        node[a] = mirror as i64;
                        // Stored by `mark`.
                        if let Some(m) = layout.index(&node) {
                            f(g, m, &self.signs[a]);
                        }
                    }
                }
            }
        }
    }

    /// Folds the ghosts into their mirrors after P2G: `m_k += m_g`, and for each vector channel
    /// `c`, `c_k += R c_g`. `gravity_impulse` (`Δt g`, m/s) is given for the channel that the grid
    /// update will add `m g Δt` to (the momentum), whose fold gets `m_g (R − I) Δt g` too; the
    /// other channels (the momentum without forces) get none. The ghosts are emptied.
    /// Node arrays are in the order of `layout`.
    pub fn fold(
        &self,
        layout: &NodeLayout<D>,
        mass: &mut [Real],
        channels: &mut [(&mut [Vector<D>], Option<Vector<D>>)],
    ) {
        self.for_each_pair(layout, |g, k, sign| {
            let m = mass[g];
            for (c, impulse) in channels.iter_mut() {
                let mut folded = c[g].component_mul(sign);
                if let Some(gdt) = impulse {
                    folded += (gdt.component_mul(sign) - *gdt) * m;
                }
                c[k] += folded;
                c[g] = Vector::<D>::zeros();
            }
            mass[k] += m;
            mass[g] = 0.0;
        });
    }

    /// Makes a mass field mirror-symmetric for interpolation (the grid density of the volume
    /// re-estimation), as if the material's mirror image lay beyond each wall plane: face by
    /// face, each ghost's mass is added to its mirror node and a node on the plane, its own
    /// image, doubles; then each ghost takes its mirror's mass. A stencil that reaches across the
    /// plane then sees no density deficit.
    pub fn mirror_mass(&self, layout: &NodeLayout<D>, mass: &mut [Real]) {
        self.for_each_layer(layout, 0, |g, k, _| {
            mass[k] += mass[g];
            if g != k {
                mass[g] = 0.0;
            }
        });
        self.for_each_pair(layout, |g, k, _| mass[g] = mass[k]);
    }

    /// Sets every ghost's velocity to the reflected velocity of its mirror node (after the
    /// boundaries), face by face in the fold's order: a corner ghost is first given a value from
    /// a ghost of a later axis, then overwritten from a ghost the earlier axis already filled, so
    /// it ends with both reflections.
    pub fn fill(&self, layout: &NodeLayout<D>, velocity: &mut [Vector<D>]) {
        self.for_each_pair(layout, |g, k, sign| {
            velocity[g] = velocity[k].component_mul(sign)
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boundary::Contact;

    fn walls(kind: ContactKind, thickness: usize) -> DomainWalls {
        DomainWalls {
            contact: Contact {
                kind,
                friction: 0.0,
            },
            thickness,
            treatment: WallTreatment::Mirror,
        }
    }

    #[test]
    fn fold_moves_mass_and_reflected_momentum_into_the_mirror_nodes() {
        // 12 × 12 nodes, 3 layers: planes at 2 and 9 on both axes; ghosts 0, 1, 10 and 11.
        let spec = GridSpec::<2>::new(Vector::<2>::zeros(), 0.1, [12, 12]);
        let mw = MirrorWalls::new(&spec, &walls(ContactKind::Slip, 3))
            .unwrap()
            .unwrap();
        let layout = NodeLayout::dense(&spec);
        let n = layout.len();
        let mass: Vec<Real> = (0..n).map(|i| 1.0 + i as Real).collect();
        let p: Vec<Vector<2>> = (0..n)
            .map(|i| Vector::<2>::new(i as Real, -(i as Real) * 0.5))
            .collect();
        let (mut m2, mut p2) = (mass.clone(), p.clone());
        let gdt = Vector::<2>::new(0.0, -0.1);
        mw.fold(&layout, &mut m2, &mut [(&mut p2, Some(gdt))]);
        // Mass is conserved and the ghosts are empty.
        let total: Real = mass.iter().sum();
        assert!((m2.iter().sum::<Real>() - total).abs() < 1e-9 * total);
        let idx = |i: i64, j: i64| layout.index(&[i, j]).unwrap();
        for (i, j) in [
            (0, 5),
            (1, 5),
            (10, 5),
            (11, 5),
            (5, 0),
            (5, 1),
            (5, 10),
            (5, 11),
        ] {
            assert_eq!(m2[idx(i, j)], 0.0);
            assert_eq!(p2[idx(i, j)], Vector::<2>::zeros());
        }
        // Node (3, 5) receives ghost (1, 5) across the left wall: x odd, y even; gravity is
        // tangential there, so R g − g = 0.
        let (k, g) = (idx(3, 5), idx(1, 5));
        assert_eq!(m2[k], mass[k] + mass[g]);
        assert_eq!(p2[k], p[k] + Vector::<2>::new(-p[g].x, p[g].y));
        // Node (5, 4) receives ghost (5, 0) across the bottom wall: y odd, gravity normal, so
        // the fold adds m_g (−g − g) Δt along y.
        let (k, g) = (idx(5, 4), idx(5, 0));
        assert_eq!(m2[k], mass[k] + mass[g]);
        let expect =
            p[k] + Vector::<2>::new(p[g].x, -p[g].y) + Vector::<2>::new(0.0, 0.2) * mass[g];
        assert!((p2[k] - expect).norm() < 1e-12 * expect.norm());
        // The corner ghost (0, 0) reaches (4, 4) with both reflections.
        let (k, g) = (idx(4, 4), idx(0, 0));
        let expect = mass[k] + mass[g] + mass[idx(4, 0)] + mass[idx(0, 4)];
        assert!((m2[k] - expect).abs() < 1e-12 * expect);
    }

    #[test]
    fn fill_reflects_and_the_plane_sees_an_odd_normal_component() {
        let spec = GridSpec::<3>::new(Vector::<3>::zeros(), 0.1, [12, 13, 14]);
        for (kind, tangent) in [(ContactKind::Slip, 1.0), (ContactKind::Sticky, -1.0)] {
            let mw = MirrorWalls::new(&spec, &walls(kind, 3)).unwrap().unwrap();
            let layout = NodeLayout::dense(&spec);
            let n = layout.len();
            let mut v: Vec<Vector<3>> = (0..n)
                .map(|i| Vector::<3>::new(1.0 + i as Real, 2.0 * i as Real, -(i as Real)))
                .collect();
            mw.fill(&layout, &mut v);
            let idx = |i: i64, j: i64, l: i64| layout.index(&[i, j, l]).unwrap();
            // Across the high y-wall (plane j = 10): ghost j = 12 mirrors j = 8.
            let (g, k) = (v[idx(5, 12, 6)], v[idx(5, 8, 6)]);
            assert_eq!(g, Vector::<3>::new(tangent * k.x, -k.y, tangent * k.z));
            // Interpolating across the plane with a symmetric kernel: the odd components of
            // (ghost + mirror)/2 vanish on the plane.
            let mid = (g + k) * 0.5;
            assert_eq!(mid.y, 0.0);
            // A corner ghost carries both reflections: x and y each flip once as the normal and
            // once more as a tangent of a sticky wall.
            let (g, k) = (v[idx(0, 0, 6)], v[idx(4, 4, 6)]);
            assert_eq!(g, Vector::<3>::new(-tangent * k.x, -tangent * k.y, k.z));
        }
    }

    #[test]
    fn unsupported_contacts_and_small_grids_are_refused() {
        let spec = GridSpec::<2>::new(Vector::<2>::zeros(), 0.1, [12, 12]);
        assert!(MirrorWalls::new(&spec, &walls(ContactKind::Separate, 3)).is_err());
        let mut w = walls(ContactKind::Slip, 3);
        w.contact.friction = 0.3;
        assert!(MirrorWalls::new(&spec, &w).is_err());
        assert!(MirrorWalls::new(&spec, &walls(ContactKind::Slip, 4)).is_err());
        w.treatment = WallTreatment::Nodes;
        assert_eq!(MirrorWalls::new(&spec, &w), Ok(None));
    }

    #[test]
    fn sparse_fold_and_fill_equal_the_dense_ones_where_material_is() {
        // 42³ nodes, walls 3 layers thick: the high x-plane is node 39 (block 4 of 8 nodes),
        // its ghosts 40 and 41 lie in block 5. Material only in block (5, 0, 0): `mark` must
        // add block (4, 0, 0), which holds the ghosts' mirrors 38 and 37.
        let spec = GridSpec::<3>::new(Vector::<3>::zeros(), 0.1, [42, 42, 42]);
        let mw = MirrorWalls::new(&spec, &walls(ContactKind::Slip, 3))
            .unwrap()
            .unwrap();
        let dense = NodeLayout::dense(&spec);
        let mut sparse = NodeLayout::default();
        sparse.begin(&spec);
        sparse.mark([5, 0, 0]);
        mw.mark(&mut sparse);
        sparse.finish();
        assert_eq!(sparse.active().len(), 2);
        assert!(sparse.index(&[38, 4, 4]).is_some());
        let value = |n: &[i64; 3]| {
            if (40..42).contains(&n[0]) && n[1] < 8 && n[2] < 8 {
                1.0 + (n[0] + 3 * n[1] + 7 * n[2]) as Real
            } else {
                0.0
            }
        };
        let fill = |layout: &NodeLayout<3>| {
            let m: Vec<Real> = (0..layout.len()).map(|i| value(&layout.node(i))).collect();
            let p: Vec<Vector<3>> = m
                .iter()
                .map(|&m| Vector::<3>::new(m, -m, 0.5 * m))
                .collect();
            (m, p)
        };
        let gdt = Vector::<3>::new(0.0, 0.0, -0.1);
        let (mut md, mut pd) = fill(&dense);
        mw.fold(&dense, &mut md, &mut [(&mut pd, Some(gdt))]);
        mw.fill(&dense, &mut pd);
        let (mut ms, mut ps) = fill(&sparse);
        mw.fold(&sparse, &mut ms, &mut [(&mut ps, Some(gdt))]);
        mw.fill(&sparse, &mut ps);
        for i in 0..dense.len() {
            let node = dense.node(i);
            match sparse.index(&node) {
                Some(k) => {
                    assert_eq!(ms[k].to_bits(), md[i].to_bits(), "{node:?}");
                    assert_eq!(ps[k], pd[i], "{node:?}");
                }
                None => assert_eq!(md[i], 0.0, "{node:?} holds mass but is not stored"),
            }
        }
        // The corner ghost (40, 0, 0) reached (38, 4, 4) across three faces.
        assert!(ms[sparse.index(&[38, 4, 4]).unwrap()] > 0.0);
    }
}
