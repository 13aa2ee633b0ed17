//! Boundary conditions applied to grid velocities: domain walls and analytic colliders.
//!
//! Each boundary has a [`Contact`] rule. With `n` the outward normal of the obstacle (pointing
//! into the material) and `v_rel = v − v_obstacle` the node velocity relative to the obstacle:
//! - `Sticky`: `v_rel = 0`;
//! - `Slip`: the normal component of `v_rel` is removed;
//! - `Separate`: the normal component is removed only when approaching (`v_rel·n < 0`).
//!
//! When the normal component is removed, Coulomb friction with coefficient `friction` reduces the
//! tangential speed by `friction · |v_rel·n|`, never reversing it.
//!
//! Domain walls are static and use the inward normal of each face of the grid box. Colliders
//! translate at a constant velocity; a node is inside a collider when the signed distance of the
//! translated shape at the node position is `≤ 0`.

use crate::grid::GridSpec;
use crate::math::{Real, Vector};
pub use crate::mirror::WallTreatment;
use serde::{Deserialize, Serialize};

/// How a boundary treats the velocity of nodes inside it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactKind {
    /// No relative motion.
    Sticky,
    /// No normal relative motion; free tangential motion (up to friction).
    #[default]
    Slip,
    /// No approaching normal motion; separation allowed.
    Separate,
}

/// A contact rule: kind and Coulomb friction coefficient (dimensionless, ≥ 0).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    /// Kind of contact.
    pub kind: ContactKind,
    /// Coulomb friction coefficient μ_f (dimensionless).
    #[serde(default)]
    pub friction: Real,
}

impl Contact {
    /// Applies the rule to velocity `v` (m/s) against an obstacle with unit normal `n` moving at
    /// `v_obstacle` (m/s).
    ///
    /// - `Sticky`: `v = v_obstacle`.
    /// - `Slip`: the normal component `v_n = v_rel·n` is always removed.
    /// - `Separate`: `v_n` is removed only when `v_n < 0` (approaching); separating velocities
    ///   are left untouched.
    ///
    /// When `v_n` is removed the tangential relative speed `|v_t|` becomes
    /// `max(|v_t| − friction·|v_n|, 0)` (direction kept, never reversed), and
    /// `v = v_obstacle + v_t`. A negative `friction` is treated as 0.
    pub fn apply<const D: usize>(&self, v: &mut Vector<D>, n: &Vector<D>, v_obstacle: &Vector<D>) {
        let v_rel = *v - v_obstacle;
        let vn = v_rel.dot(n);
        let remove_normal = match self.kind {
            ContactKind::Sticky => {
                *v = *v_obstacle;
                return;
            }
            ContactKind::Slip => true,
            ContactKind::Separate => vn < 0.0,
        };
        if !remove_normal {
            return;
        }
        let mut vt = v_rel - n * vn;
        if self.friction > 0.0 {
            let speed = vt.norm();
            let reduced = speed - self.friction * vn.abs();
            if reduced <= 0.0 || speed <= 0.0 {
                vt = Vector::<D>::zeros();
            } else {
                vt *= reduced / speed;
            }
        }
        *v = v_obstacle + vt;
    }
}

/// The walls of the grid box: nodes within `thickness` nodes of a face get the contact rule,
/// with the face's inward normal. With [`WallTreatment::Mirror`] the innermost of those layers is
/// the wall plane and the others are mirrored ghosts (`crate::mirror`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DomainWalls {
    /// Contact rule.
    pub contact: Contact,
    /// Number of node layers treated as wall on each face (≥ 1).
    pub thickness: usize,
    /// How the wall layers act on the grid.
    #[serde(default)]
    pub treatment: WallTreatment,
}

impl DomainWalls {
    /// Walls of `thickness` node layers with `contact` and the default treatment on grid `spec`:
    /// mirrored ([`WallTreatment::Mirror`]) wherever that applies (slip or sticky contact
    /// without friction, at least `4 · thickness` nodes along each axis), because only then do
    /// rest states next to a wall converge under refinement; wall node layers otherwise
    /// (separating or frictional walls, small grids).
    pub fn with_default_treatment<const D: usize>(
        contact: Contact,
        thickness: usize,
        spec: &GridSpec<D>,
    ) -> Self {
        let mirrored = Self {
            contact,
            thickness,
            treatment: WallTreatment::Mirror,
        };
        match crate::mirror::MirrorWalls::new(spec, &mirrored) {
            Ok(Some(_)) => mirrored,
            _ => Self {
                treatment: WallTreatment::Nodes,
                ..mirrored
            },
        }
    }

    /// The wall planes (m), lower and upper per axis, of grid `spec`: the innermost wall node
    /// layers, `thickness − 1` nodes in from each face.
    pub fn planes<const D: usize>(&self, spec: &GridSpec<D>) -> (Vector<D>, Vector<D>) {
        let inset = self.thickness.saturating_sub(1) as Real;
        let lo = Vector::<D>::from_fn(|a, _| spec.origin[a] + inset * spec.dx);
        let hi = Vector::<D>::from_fn(|a, _| {
            spec.origin[a] + ((spec.size[a] - 1) as Real - inset) * spec.dx
        });
        (lo, hi)
    }
}

/// Analytic collider shapes; the collider occupies the inside (signed distance ≤ 0).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "shape", rename_all = "snake_case")]
pub enum ColliderShape<const D: usize> {
    /// The half-space `{x : (x − point)·normal ≤ 0}`; `normal` (unit) points into the material.
    HalfSpace {
        /// A point on the plane (m).
        point: Vector<D>,
        /// Unit normal pointing out of the collider (m⁰).
        normal: Vector<D>,
    },
    /// A solid axis-aligned box.
    Box {
        /// Lower corner (m).
        min: Vector<D>,
        /// Upper corner (m).
        max: Vector<D>,
    },
    /// A solid sphere (disk in 2D).
    Sphere {
        /// Centre (m).
        center: Vector<D>,
        /// Radius (m).
        radius: Real,
    },
}

impl<const D: usize> ColliderShape<D> {
    /// Signed distance (m) at `x` and the unit outward normal, for the shape at rest.
    ///
    /// The distance is negative inside the collider. The normal is the gradient of the distance
    /// (pointing out of the collider, into the material):
    /// - half-space: `(x − point)·n̂` with `n̂ = normal/|normal|` (normalised defensively; a zero
    ///   or non-finite normal gives a degenerate half-space that contains nothing: `(+∞, 0)`);
    /// - box: the exact signed distance of the axis-aligned box (corners may be given in any
    ///   order). Outside, the normal points from the nearest surface point to `x`; inside, it
    ///   is the normal of the nearest face (ties go to the lowest axis);
    /// - sphere: `|x − center| − radius`, normal `(x − center)/|x − center|` (at the exact
    ///   centre, where the gradient is undefined, `+e_0`).
    pub fn signed_distance(&self, x: &Vector<D>) -> (Real, Vector<D>) {
        match self {
            ColliderShape::HalfSpace { point, normal } => {
                let len = normal.norm();
                if !(len > 0.0 && len.is_finite()) {
                    return (Real::INFINITY, Vector::<D>::zeros());
                }
                let n = normal / len;
                ((x - point).dot(&n), n)
            }
            ColliderShape::Box { min, max } => box_signed_distance(min, max, x),
            ColliderShape::Sphere { center, radius } => {
                let d = x - center;
                let r = d.norm();
                let n = if r > 0.0 { d / r } else { unit::<D>(0, 1.0) };
                (r - radius, n)
            }
        }
    }
}

/// A collider: shape, contact rule and a prescribed constant translation velocity.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Collider<const D: usize> {
    /// Shape at time 0.
    pub shape: ColliderShape<D>,
    /// Contact rule.
    pub contact: Contact,
    /// Translation velocity (m/s); the shape at time t is the shape at 0 moved by `velocity · t`.
    pub velocity: Vector<D>,
}

/// All grid boundary conditions of a simulation.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Boundaries<const D: usize> {
    /// Domain walls, if any.
    pub walls: Option<DomainWalls>,
    /// Colliders.
    pub colliders: Vec<Collider<D>>,
}

impl<const D: usize> Boundaries<D> {
    /// Frictionless slip walls `thickness` node layers thick on every face of the grid, and no
    /// colliders.
    pub fn slip_walls(thickness: usize) -> Self {
        Self {
            walls: Some(DomainWalls {
                contact: Contact {
                    kind: ContactKind::Slip,
                    friction: 0.0,
                },
                thickness,
                treatment: WallTreatment::Nodes,
            }),
            colliders: Vec::new(),
        }
    }

    /// Applies every boundary to the velocity `v` (m/s) of grid node `node` at time `t` (s).
    /// Walls first, then colliders in order.
    pub fn apply(&self, spec: &GridSpec<D>, t: Real, node: &[i64; D], v: &mut Vector<D>) {
        if let Some(walls) = &self.walls {
            let thickness = walls.thickness as i64;
            let still = Vector::<D>::zeros();
            for (a, (&k, &size)) in node.iter().zip(&spec.size).enumerate() {
                if k < thickness {
                    walls.contact.apply(v, &unit::<D>(a, 1.0), &still);
                }
                if k >= size as i64 - thickness {
                    walls.contact.apply(v, &unit::<D>(a, -1.0), &still);
                }
            }
        }
        if self.colliders.is_empty() {
            return;
        }
        let x = spec.node_position(node);
        for collider in &self.colliders {
            // The shape at time t is the shape at 0 translated by velocity·t.
            let x0 = x - collider.velocity * t;
            let (phi, n) = collider.shape.signed_distance(&x0);
            if phi <= 0.0 {
                collider.contact.apply(v, &n, &collider.velocity);
            }
        }
    }

    /// Whether there are no boundaries at all.
    pub fn is_empty(&self) -> bool {
        self.walls.is_none() && self.colliders.is_empty()
    }
}

/// `sign · e_axis`.
fn unit<const D: usize>(axis: usize, sign: Real) -> Vector<D> {
    let mut e = Vector::<D>::zeros();
    e[axis] = sign;
    e
}

/// Exact signed distance and gradient of the axis-aligned box spanned by `a` and `b`.
fn box_signed_distance<const D: usize>(
    a: &Vector<D>,
    b: &Vector<D>,
    x: &Vector<D>,
) -> (Real, Vector<D>) {
    let lo = a.inf(b);
    let hi = a.sup(b);
    let center = (lo + hi) * 0.5;
    let half = (hi - lo) * 0.5;
    let rel = x - center;
    // q_a > 0: outside the slab of axis a by q_a; q_a ≤ 0: inside, |q_a| from the nearer face.
    let q = Vector::<D>::from_fn(|k, _| rel[k].abs() - half[k]);
    let sign = |k: usize| if rel[k] < 0.0 { -1.0 } else { 1.0 };
    let outside = Vector::<D>::from_fn(|k, _| sign(k) * q[k].max(0.0));
    let dist = outside.norm();
    if dist > 0.0 {
        return (dist, outside / dist);
    }
    // Inside or on the surface: the nearest face is the axis with the largest q.
    let mut axis = 0;
    for k in 1..D {
        if q[k] > q[axis] {
            axis = k;
        }
    }
    (q[axis], unit::<D>(axis, sign(axis)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn contact(kind: ContactKind, friction: Real) -> Contact {
        Contact { kind, friction }
    }

    fn v2(x: Real, y: Real) -> Vector<2> {
        Vector::<2>::new(x, y)
    }

    fn v3(x: Real, y: Real, z: Real) -> Vector<3> {
        Vector::<3>::new(x, y, z)
    }

    /// Walls are mirrored by default where the mirror applies, and keep wall node layers where
    /// it does not (no reflection for separation or friction; too few nodes for the ghosts);
    /// the wall planes are the innermost wall layers either way.
    #[test]
    fn walls_are_mirrored_by_default_where_the_mirror_applies() {
        let spec = GridSpec::<2>::new(v2(-0.2, 0.0), 0.1, [20, 12]);
        let treatment = |c: Contact, t: usize| DomainWalls::with_default_treatment(c, t, &spec);
        for kind in [ContactKind::Slip, ContactKind::Sticky] {
            assert_eq!(
                treatment(contact(kind, 0.0), 3).treatment,
                WallTreatment::Mirror
            );
            assert_eq!(
                treatment(contact(kind, 0.3), 3).treatment,
                WallTreatment::Nodes
            );
        }
        let separate = contact(ContactKind::Separate, 0.0);
        assert_eq!(treatment(separate, 3).treatment, WallTreatment::Nodes);
        // 12 nodes along y hold the mirrors of thickness 3, not of thickness 4.
        let slip = contact(ContactKind::Slip, 0.0);
        assert_eq!(treatment(slip, 4).treatment, WallTreatment::Nodes);
        let w = treatment(slip, 3);
        assert_eq!((w.contact, w.thickness), (slip, 3));
        let (lo, hi) = w.planes(&spec);
        assert_relative_eq!(lo, v2(0.0, 0.2), epsilon = 1e-12);
        assert_relative_eq!(hi, v2(1.5, 0.9), epsilon = 1e-12);
    }

    fn applied<const D: usize>(
        c: Contact,
        v: Vector<D>,
        n: Vector<D>,
        obs: Vector<D>,
    ) -> Vector<D> {
        let mut v = v;
        c.apply(&mut v, &n, &obs);
        v
    }

    #[test]
    fn sticky_zeroes_relative_velocity() {
        let sticky = contact(ContactKind::Sticky, 0.7);
        let obs = v2(0.5, -1.0);
        assert_eq!(applied(sticky, v2(1.0, 2.0), v2(0.0, 1.0), obs), obs);
        assert_eq!(applied(sticky, v2(-3.0, 0.0), v2(0.6, 0.8), obs), obs);
        let obs = v3(0.1, 0.2, 0.3);
        assert_eq!(
            applied(sticky, v3(4.0, -5.0, 6.0), v3(0.0, 0.0, 1.0), obs),
            obs
        );
    }

    #[test]
    fn slip_removes_only_the_normal_part() {
        let slip = contact(ContactKind::Slip, 0.0);
        let up = v2(0.0, 1.0);
        // Approaching and separating normal motion are both removed, tangential kept exactly.
        assert_eq!(
            applied(slip, v2(3.0, -2.0), up, Vector::zeros()),
            v2(3.0, 0.0)
        );
        assert_eq!(
            applied(slip, v2(3.0, 2.0), up, Vector::zeros()),
            v2(3.0, 0.0)
        );
        // Relative to a moving obstacle: v_rel = (2, −2.5) → (2, 0), v = v_obs + (2, 0).
        assert_eq!(applied(slip, v2(3.0, -2.0), up, v2(1.0, 0.5)), v2(3.0, 0.5));
        // Oblique normal: no normal relative motion remains, tangential part unchanged.
        let n = v2(0.6, 0.8);
        let t = v2(-0.8, 0.6);
        let v = v2(1.0, -2.0);
        let out = applied(slip, v, n, Vector::zeros());
        assert!(out.dot(&n).abs() < 1e-15);
        assert_relative_eq!(out.dot(&t), v.dot(&t), epsilon = 1e-15);
        // 3D.
        let out = applied(
            slip,
            v3(1.0, -2.0, -3.0),
            v3(0.0, 0.0, 1.0),
            Vector::zeros(),
        );
        assert_eq!(out, v3(1.0, -2.0, 0.0));
    }

    #[test]
    fn separate_only_removes_approaching_motion() {
        let up = v2(0.0, 1.0);
        for friction in [0.0, 0.5] {
            let sep = contact(ContactKind::Separate, friction);
            // Separating: untouched, even with friction.
            assert_eq!(
                applied(sep, v2(3.0, 2.0), up, Vector::zeros()),
                v2(3.0, 2.0)
            );
            assert_eq!(
                applied(sep, v2(3.0, 0.0), up, Vector::zeros()),
                v2(3.0, 0.0)
            );
            // Separating relative to a moving obstacle: v_rel = (0, 0.5).
            assert_eq!(applied(sep, v2(1.0, 1.5), up, v2(1.0, 1.0)), v2(1.0, 1.5));
        }
        let sep = contact(ContactKind::Separate, 0.0);
        assert_eq!(
            applied(sep, v2(3.0, -2.0), up, Vector::zeros()),
            v2(3.0, 0.0)
        );
        // Approaching relative to an obstacle moving up faster than the node.
        assert_eq!(applied(sep, v2(3.0, 0.5), up, v2(0.0, 1.0)), v2(3.0, 1.0));
    }

    #[test]
    fn friction_reduces_tangential_speed_without_reversal() {
        let up = v2(0.0, 1.0);
        for kind in [ContactKind::Slip, ContactKind::Separate] {
            // |v_t| = 3, μ|v_n| = 0.5 · 2 = 1 → |v_t| = 2.
            let c = contact(kind, 0.5);
            assert_eq!(applied(c, v2(3.0, -2.0), up, Vector::zeros()), v2(2.0, 0.0));
            assert_eq!(
                applied(c, v2(-3.0, -2.0), up, Vector::zeros()),
                v2(-2.0, 0.0)
            );
            // Relative to a moving obstacle: v_rel = (2, −2) → (1, 0).
            assert_eq!(applied(c, v2(3.0, -1.0), up, v2(1.0, 1.0)), v2(2.0, 1.0));
            // μ|v_n| larger than |v_t|: the node stops relative to the obstacle, no reversal.
            let c = contact(kind, 10.0);
            assert_eq!(applied(c, v2(3.0, -2.0), up, Vector::zeros()), v2(0.0, 0.0));
            assert_eq!(applied(c, v2(3.0, -2.0), up, v2(1.0, 0.0)), v2(1.0, 0.0));
            let c = contact(kind, 1.5);
            assert_eq!(applied(c, v2(3.0, -2.0), up, Vector::zeros()), v2(0.0, 0.0));
        }
        // Slip also applies friction with |v_n| when separating.
        let slip = contact(ContactKind::Slip, 0.5);
        assert_eq!(
            applied(slip, v2(3.0, 2.0), up, Vector::zeros()),
            v2(2.0, 0.0)
        );
        // 3D: |v_t| = 5 → 5 − 0.2 · 5 = 4, direction kept.
        let c = contact(ContactKind::Slip, 0.2);
        let out = applied(c, v3(3.0, 4.0, -5.0), v3(0.0, 0.0, 1.0), Vector::zeros());
        assert_relative_eq!(out, v3(2.4, 3.2, 0.0), epsilon = 1e-15);
    }

    /// Central finite-difference gradient of the signed distance.
    fn fd_gradient<const D: usize>(shape: &ColliderShape<D>, x: &Vector<D>) -> Vector<D> {
        let h = 1e-6;
        Vector::<D>::from_fn(|a, _| {
            let mut e = Vector::<D>::zeros();
            e[a] = h;
            (shape.signed_distance(&(x + e)).0 - shape.signed_distance(&(x - e)).0) / (2.0 * h)
        })
    }

    #[test]
    fn signed_distance_of_sphere_box_and_half_space() {
        let sphere = ColliderShape::Sphere {
            center: v2(1.0, 2.0),
            radius: 0.5,
        };
        let (phi, n) = sphere.signed_distance(&v2(1.0, 3.0));
        assert_relative_eq!(phi, 0.5, epsilon = 1e-15);
        assert_relative_eq!(n, v2(0.0, 1.0), epsilon = 1e-15);
        let (phi, n) = sphere.signed_distance(&v2(1.2, 2.0));
        assert_relative_eq!(phi, -0.3, epsilon = 1e-15);
        assert_relative_eq!(n, v2(1.0, 0.0), epsilon = 1e-15);
        let (phi, n) = sphere.signed_distance(&v2(1.0, 2.0));
        assert_eq!(phi, -0.5);
        assert_relative_eq!(n.norm(), 1.0, epsilon = 1e-15);

        let sphere3 = ColliderShape::Sphere {
            center: v3(0.0, 0.0, 0.0),
            radius: 1.0,
        };
        let (phi, n) = sphere3.signed_distance(&v3(2.0, 0.0, 2.0));
        assert_relative_eq!(phi, 8f64.sqrt() - 1.0, epsilon = 1e-15);
        assert_relative_eq!(n, v3(1.0, 0.0, 1.0) / 2f64.sqrt(), epsilon = 1e-15);

        // 2D box [0, 2] × [0, 1].
        let bx = ColliderShape::Box {
            min: v2(0.0, 0.0),
            max: v2(2.0, 1.0),
        };
        let cases = [
            // (point, φ, normal)
            (v2(3.0, 2.0), 2f64.sqrt(), v2(1.0, 1.0) / 2f64.sqrt()),
            (v2(1.0, -0.5), 0.5, v2(0.0, -1.0)),
            (v2(-0.25, 0.5), 0.25, v2(-1.0, 0.0)),
            (v2(1.0, 0.2), -0.2, v2(0.0, -1.0)),
            (v2(1.9, 0.5), -0.1, v2(1.0, 0.0)),
            (v2(0.6, 0.7), -0.3, v2(0.0, 1.0)),
            (v2(2.0, 0.5), 0.0, v2(1.0, 0.0)),
        ];
        for (x, phi_ref, n_ref) in cases {
            let (phi, n) = bx.signed_distance(&x);
            assert_relative_eq!(phi, phi_ref, epsilon = 1e-15);
            assert_relative_eq!(n, n_ref, epsilon = 1e-15);
        }
        // The same box with swapped corners.
        let swapped = ColliderShape::Box {
            min: v2(2.0, 1.0),
            max: v2(0.0, 0.0),
        };
        assert_eq!(
            swapped.signed_distance(&v2(1.0, 0.2)),
            (-0.2, v2(0.0, -1.0))
        );

        // 3D box: normals are unit and equal the gradient away from kinks.
        let bx3 = ColliderShape::Box {
            min: v3(-1.0, 0.0, 0.5),
            max: v3(1.0, 2.0, 1.5),
        };
        let (phi, n) = bx3.signed_distance(&v3(0.0, 1.0, 0.6));
        assert_relative_eq!(phi, -0.1, epsilon = 1e-15);
        assert_relative_eq!(n, v3(0.0, 0.0, -1.0), epsilon = 1e-15);
        let (phi, n) = bx3.signed_distance(&v3(2.0, 3.0, 2.5));
        assert_relative_eq!(phi, 3f64.sqrt(), epsilon = 1e-15);
        assert_relative_eq!(n, v3(1.0, 1.0, 1.0) / 3f64.sqrt(), epsilon = 1e-15);
        for x in [
            v3(0.3, 0.4, 1.0),
            v3(1.7, 0.3, 1.0),
            v3(-1.3, 2.6, 0.1),
            v3(0.2, -0.5, 2.0),
            v3(0.9, 1.0, 0.8),
        ] {
            let (_, n) = bx3.signed_distance(&x);
            assert_relative_eq!(n.norm(), 1.0, epsilon = 1e-15);
            assert_relative_eq!(n, fd_gradient(&bx3, &x), epsilon = 1e-8);
            let (_, n) = sphere3.signed_distance(&x);
            assert_relative_eq!(n.norm(), 1.0, epsilon = 1e-15);
            assert_relative_eq!(n, fd_gradient(&sphere3, &x), epsilon = 1e-8);
        }

        // Half-space with a non-unit normal: normalised.
        let floor = ColliderShape::HalfSpace {
            point: v2(0.0, 1.0),
            normal: v2(0.0, 2.0),
        };
        assert_eq!(floor.signed_distance(&v2(5.0, 3.0)), (2.0, v2(0.0, 1.0)));
        assert_eq!(floor.signed_distance(&v2(5.0, 0.5)), (-0.5, v2(0.0, 1.0)));
        let degenerate = ColliderShape::HalfSpace {
            point: v2(0.0, 1.0),
            normal: v2(0.0, 0.0),
        };
        assert!(degenerate.signed_distance(&v2(0.0, 0.0)).0 > 0.0);
    }

    #[test]
    fn moving_sphere_collider_imposes_its_velocity() {
        let spec = GridSpec::<2>::new(Vector::zeros(), 0.1, [20, 20]);
        let u = v2(1.0, 0.0);
        let b = Boundaries {
            walls: None,
            colliders: vec![Collider {
                shape: ColliderShape::Sphere {
                    center: v2(0.5, 0.5),
                    radius: 0.15,
                },
                contact: contact(ContactKind::Sticky, 0.0),
                velocity: u,
            }],
        };
        // At t = 0.5 s the sphere is centred at (1.0, 0.5).
        let t = 0.5;
        let mut v = v2(-2.0, 3.0);
        b.apply(&spec, t, &[10, 5], &mut v);
        assert_eq!(v, u);
        let mut v = v2(-2.0, 3.0);
        b.apply(&spec, t, &[11, 6], &mut v); // distance √2·0.1 < 0.15
        assert_eq!(v, u);
        // Inside the sphere at rest, outside the translated one: untouched.
        let mut v = v2(-2.0, 3.0);
        b.apply(&spec, t, &[5, 5], &mut v);
        assert_eq!(v, v2(-2.0, 3.0));
        let mut v = v2(-2.0, 3.0);
        b.apply(&spec, 0.0, &[5, 5], &mut v);
        assert_eq!(v, u);

        // 3D: a slip floor moving sideways, and a sticky sphere moving diagonally.
        let spec = GridSpec::<3>::new(Vector::zeros(), 0.1, [10, 10, 10]);
        let w = v3(0.2, 0.2, 0.0);
        let b = Boundaries {
            walls: None,
            colliders: vec![
                Collider {
                    shape: ColliderShape::HalfSpace {
                        point: v3(0.0, 0.0, 0.25),
                        normal: v3(0.0, 0.0, 1.0),
                    },
                    contact: contact(ContactKind::Slip, 0.0),
                    velocity: v3(0.5, 0.0, 0.0),
                },
                Collider {
                    shape: ColliderShape::Sphere {
                        center: v3(0.3, 0.3, 0.6),
                        radius: 0.12,
                    },
                    contact: contact(ContactKind::Sticky, 0.0),
                    velocity: w,
                },
            ],
        };
        let t = 1.0; // sphere centred at (0.5, 0.5, 0.6)
        let mut v = v3(1.0, 2.0, -3.0);
        b.apply(&spec, t, &[4, 4, 2], &mut v); // below the floor plane z = 0.25
        assert_eq!(v, v3(1.0, 2.0, 0.0));
        let mut v = v3(1.0, 2.0, -3.0);
        b.apply(&spec, t, &[4, 4, 3], &mut v); // above it, outside the sphere
        assert_eq!(v, v3(1.0, 2.0, -3.0));
        let mut v = v3(1.0, 2.0, -3.0);
        b.apply(&spec, t, &[5, 5, 6], &mut v);
        assert_eq!(v, w);
    }

    /// Applies `b` to `v` at every node of `spec`, returning the nodes whose velocity changed.
    fn changed_nodes<const D: usize>(
        b: &Boundaries<D>,
        spec: &GridSpec<D>,
        v: Vector<D>,
    ) -> Vec<([i64; D], Vector<D>)> {
        (0..spec.num_nodes())
            .filter_map(|i| {
                let node = spec.multi_index(i);
                let mut w = v;
                b.apply(spec, 0.0, &node, &mut w);
                (w != v).then_some((node, w))
            })
            .collect()
    }

    #[test]
    fn domain_walls_act_on_the_right_layers_2d() {
        // 10 × 8 nodes, two wall layers: x-walls at i ∈ {0, 1, 8, 9}, y-walls at j ∈ {0, 1, 6, 7}.
        let spec = GridSpec::<2>::new(v2(-1.0, 2.0), 0.1, [10, 8]);
        let walls = |kind| Boundaries {
            walls: Some(DomainWalls {
                contact: contact(kind, 0.0),
                thickness: 2,
                treatment: Default::default(),
            }),
            colliders: vec![],
        };
        let x_wall = |i: i64| !(2..8).contains(&i);
        let y_wall = |j: i64| !(2..6).contains(&j);
        // Slip removes the wall-normal component in every wall layer, approaching or not.
        for v in [v2(-1.0, -1.0), v2(1.0, 1.0), v2(1.0, -1.0)] {
            let changed = changed_nodes(&walls(ContactKind::Slip), &spec, v);
            assert_eq!(changed.len(), 10 * 8 - 6 * 4);
            for (node, w) in changed {
                let (wx, wy) = (x_wall(node[0]), y_wall(node[1]));
                assert!(wx || wy, "{node:?}");
                assert_eq!(
                    w,
                    v2(if wx { 0.0 } else { v.x }, if wy { 0.0 } else { v.y })
                );
            }
        }
        // Separate: moving towards −x, −y, only the low layers 0, 1 of each axis react.
        let sep = walls(ContactKind::Separate);
        let changed = changed_nodes(&sep, &spec, v2(-1.0, -1.0));
        assert_eq!(changed.len(), 10 * 8 - 8 * 6);
        for (node, w) in changed {
            let (wx, wy) = (node[0] < 2, node[1] < 2);
            assert!(wx || wy, "{node:?}");
            assert_eq!(
                w,
                v2(if wx { 0.0 } else { -1.0 }, if wy { 0.0 } else { -1.0 })
            );
        }
        // Moving towards +x, −y: layers 8, 9 (x) and 0, 1 (y).
        let changed = changed_nodes(&sep, &spec, v2(1.0, -1.0));
        assert_eq!(changed.len(), 10 * 8 - 8 * 6);
        for (node, w) in changed {
            let (wx, wy) = (node[0] >= 8, node[1] < 2);
            assert!(wx || wy, "{node:?}");
            assert_eq!(
                w,
                v2(if wx { 0.0 } else { 1.0 }, if wy { 0.0 } else { -1.0 })
            );
        }
        // Layer 2 (x) and layer 5 (y) are not walls.
        let mut v = v2(-1.0, 1.0);
        sep.apply(&spec, 0.0, &[2, 5], &mut v);
        assert_eq!(v, v2(-1.0, 1.0));
    }

    #[test]
    fn domain_walls_act_on_the_right_layers_3d() {
        let spec = GridSpec::<3>::new(Vector::zeros(), 0.1, [6, 7, 8]);
        let b = Boundaries {
            walls: Some(DomainWalls {
                contact: contact(ContactKind::Sticky, 0.0),
                thickness: 1,
                treatment: Default::default(),
            }),
            colliders: vec![],
        };
        let changed = changed_nodes(&b, &spec, v3(0.3, -0.2, 0.1));
        assert_eq!(changed.len(), 6 * 7 * 8 - 4 * 5 * 6);
        for (node, w) in changed {
            let on_wall = (0..3).any(|a| node[a] == 0 || node[a] == spec.size[a] as i64 - 1);
            assert!(on_wall, "{node:?}");
            assert_eq!(w, Vector::<3>::zeros());
        }
        // Slip on the top z layer keeps the in-plane motion.
        let slip = Boundaries {
            walls: Some(DomainWalls {
                contact: contact(ContactKind::Slip, 0.0),
                thickness: 2,
                treatment: Default::default(),
            }),
            colliders: vec![],
        };
        let mut v = v3(0.3, -0.2, 0.1);
        slip.apply(&spec, 0.0, &[3, 3, 6], &mut v);
        assert_eq!(v, v3(0.3, -0.2, 0.0));
        let mut v = v3(0.3, -0.2, 0.1);
        slip.apply(&spec, 0.0, &[3, 3, 5], &mut v);
        assert_eq!(v, v3(0.3, -0.2, 0.1));
    }
}
