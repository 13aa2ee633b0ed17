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

use crate::grid::GridSpec;
use crate::math::{Real, Vector};
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
    pub fn apply<const D: usize>(&self, v: &mut Vector<D>, n: &Vector<D>, v_obstacle: &Vector<D>) {
        todo!("{v}{n}{v_obstacle}")
    }
}

/// The walls of the grid box: nodes within `thickness` nodes of a face get the contact rule,
/// with the face's inward normal.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DomainWalls {
    /// Contact rule.
    pub contact: Contact,
    /// Number of node layers treated as wall on each face (≥ 1).
    pub thickness: usize,
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
    pub fn signed_distance(&self, x: &Vector<D>) -> (Real, Vector<D>) {
        todo!("{x}")
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
    /// Applies every boundary to the velocity `v` (m/s) of grid node `node` at time `t` (s).
    /// Walls first, then colliders in order.
    pub fn apply(&self, spec: &GridSpec<D>, t: Real, node: &[i64; D], v: &mut Vector<D>) {
        todo!("{spec:?}{t}{node:?}{v}")
    }

    /// Whether there are no boundaries at all.
    pub fn is_empty(&self) -> bool {
        self.walls.is_none() && self.colliders.is_empty()
    }
}
