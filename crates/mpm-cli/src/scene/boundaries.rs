//! `[[boundaries]]`: the walls of the grid box and colliders, with their contact rule.

use super::grid::Grid;
use super::Checker;
use crate::build::vector;
use mpm_core::boundary::{Contact, ContactKind, DomainWalls, WallTreatment};
use mpm_core::GridSpec;
use serde::{Deserialize, Serialize};

/// Boundary kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BoundaryKind {
    /// The walls of the grid box.
    Walls,
    /// A half-space collider.
    HalfSpace,
    /// A box collider.
    Box,
    /// A sphere collider.
    Sphere,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawBoundary {
    #[serde(rename = "type")]
    kind: BoundaryKind,
    contact: Option<ContactKind>,
    friction: Option<f64>,
    velocity: Option<Vec<f64>>,
    thickness: Option<u32>,
    treatment: Option<WallTreatment>,
    point: Option<Vec<f64>>,
    normal: Option<Vec<f64>>,
    min: Option<Vec<f64>>,
    max: Option<Vec<f64>>,
    center: Option<Vec<f64>>,
    radius: Option<f64>,
}

/// One `[[boundaries]]` entry.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BoundaryDef {
    /// Kind and geometry.
    #[serde(flatten)]
    pub geometry: BoundaryGeometry,
    /// Contact rule.
    pub contact: ContactKind,
    /// Coulomb friction coefficient.
    pub friction: f64,
    /// Translation velocity of a collider (m/s); walls do not move.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub velocity: Option<Vec<f64>>,
}

/// Boundary kinds with their geometry.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum BoundaryGeometry {
    /// Walls of the grid box.
    Walls {
        /// Node layers per face.
        thickness: u32,
        /// How the layers act on the grid (explicit solver).
        treatment: WallTreatment,
    },
    /// Half-space `(x − point)·normal ≤ 0`.
    HalfSpace {
        /// A point on the plane (m).
        point: Vec<f64>,
        /// Normal pointing out of the collider, into the material.
        normal: Vec<f64>,
    },
    /// Solid box.
    Box {
        /// Lower corner (m).
        min: Vec<f64>,
        /// Upper corner (m).
        max: Vec<f64>,
    },
    /// Solid sphere.
    Sphere {
        /// Centre (m).
        center: Vec<f64>,
        /// Radius (m).
        radius: f64,
    },
}

/// Resolves `[[boundaries]]`; the domain walls may be given once.
/// Resolves `[[boundaries]]` on `grid` for a solver that mirrors walls (`mirrors`: the
/// explicit solver), which gives walls without `treatment` the default treatment
/// ([`DomainWalls::with_default_treatment`]); other solvers' walls get wall node layers.
pub(super) fn resolve_boundaries(
    c: &mut Checker<'_>,
    raw: &[RawBoundary],
    (grid, d): (&Grid, usize),
    mirrors: bool,
) -> Vec<BoundaryDef> {
    let boundaries: Vec<BoundaryDef> = raw
        .iter()
        .enumerate()
        .map(|(i, b)| resolve_boundary(c, i, b, (grid, d), mirrors))
        .collect();
    let walls = boundaries
        .iter()
        .enumerate()
        .filter(|(_, b)| matches!(b.geometry, BoundaryGeometry::Walls { .. }))
        .map(|(i, _)| i)
        .collect::<Vec<_>>();
    if let Some(&second) = walls.get(1) {
        c.err(
            &format!("boundaries[{second}].type"),
            "the domain walls are given twice",
        );
    }
    boundaries
}

/// An error at the `treatment` key of mirrored walls in a scene of `solver`, which has its own
/// wall treatment (mirrored walls act on the explicit solver's grid).
pub(crate) fn refuse_mirrored_walls(c: &mut Checker<'_>, boundaries: &[BoundaryDef], solver: &str) {
    for (i, b) in boundaries.iter().enumerate() {
        if let BoundaryGeometry::Walls {
            treatment: WallTreatment::Mirror,
            ..
        } = b.geometry
        {
            c.err(
                &format!("boundaries[{i}].treatment"),
                format!(
                    "mirrored walls act on the explicit solver's grid; solver \"{solver}\" has \
                     its own wall treatment: leave out `treatment`"
                ),
            );
        }
    }
}

/// The default treatment of walls of `thickness` layers with `contact` on `grid`; node layers
/// on a grid the scene's checks refuse (its errors are reported at the grid's keys), so that no
/// grid size is computed from values out of range.
fn default_treatment(contact: Contact, thickness: usize, grid: &Grid, d: usize) -> WallTreatment {
    let valid = grid.dx > 0.0
        && grid.dx.is_finite()
        && grid.min.len() == d
        && grid.max.len() == d
        && (0..d).all(|a| {
            let nodes = (grid.max[a] - grid.min[a]) / grid.dx;
            nodes.is_finite() && (1.0..=1e9).contains(&nodes)
        });
    if !valid {
        return WallTreatment::Nodes;
    }
    fn on<const D: usize>(contact: Contact, thickness: usize, g: &Grid) -> WallTreatment {
        let spec = GridSpec::<D>::covering(vector::<D>(&g.min), vector::<D>(&g.max), g.dx);
        DomainWalls::with_default_treatment(contact, thickness, &spec).treatment
    }
    match d {
        2 => on::<2>(contact, thickness, grid),
        _ => on::<3>(contact, thickness, grid),
    }
}

fn resolve_boundary(
    c: &mut Checker<'_>,
    i: usize,
    b: &RawBoundary,
    (grid, d): (&Grid, usize),
    mirrors: bool,
) -> BoundaryDef {
    let k = |name: &str| format!("boundaries[{i}].{name}");
    let kind_name = super::serde_plain(&b.kind);
    let present = [
        ("thickness", b.thickness.is_some()),
        ("treatment", b.treatment.is_some()),
        ("point", b.point.is_some()),
        ("normal", b.normal.is_some()),
        ("min", b.min.is_some()),
        ("max", b.max.is_some()),
        ("center", b.center.is_some()),
        ("radius", b.radius.is_some()),
        ("velocity", b.velocity.is_some()),
    ];
    let used: &[&str] = match b.kind {
        BoundaryKind::Walls => &["thickness", "treatment"],
        BoundaryKind::HalfSpace => &["point", "normal", "velocity"],
        BoundaryKind::Box => &["min", "max", "velocity"],
        BoundaryKind::Sphere => &["center", "radius", "velocity"],
    };
    for (key, p) in present {
        if !used.contains(&key) {
            c.not_applicable(&k(key), p, &format!("to type = \"{kind_name}\""));
        }
    }
    let what = format!("type = \"{kind_name}\"");
    let need_vec = |c: &mut Checker<'_>, key: &str, v: &Option<Vec<f64>>| {
        c.required_vector(&k(key), v.as_deref(), d, &what)
    };
    let geometry = match b.kind {
        BoundaryKind::Walls => {
            let t = b.thickness.unwrap_or(3);
            if !(1..=16).contains(&t) {
                c.err(&k("thickness"), format!("must lie in 1..=16 (got {t})"));
            }
            let contact = Contact {
                kind: b.contact.unwrap_or(ContactKind::Slip),
                friction: b.friction.unwrap_or(0.0),
            };
            let treatment = match b.treatment {
                Some(t) => t,
                None if mirrors => default_treatment(contact, t as usize, grid, d),
                None => WallTreatment::Nodes,
            };
            if treatment == WallTreatment::Mirror {
                let contact = b.contact.unwrap_or_default();
                if contact == ContactKind::Separate || b.friction.is_some_and(|f| f != 0.0) {
                    c.err(
                        &k("treatment"),
                        "mirrored walls reflect the grid across the wall plane, which needs \
                         contact = \"slip\" or \"sticky\" without friction",
                    );
                }
            }
            BoundaryGeometry::Walls {
                thickness: t,
                treatment,
            }
        }
        BoundaryKind::HalfSpace => {
            let point = need_vec(c, "point", &b.point);
            let normal = need_vec(c, "normal", &b.normal);
            let n: f64 = normal.iter().map(|x| x * x).sum::<f64>().sqrt();
            if normal.len() == d && !(n > 0.0 && n.is_finite()) {
                c.err(&k("normal"), "must be a non-zero finite vector");
            }
            BoundaryGeometry::HalfSpace { point, normal }
        }
        BoundaryKind::Box => {
            let min = need_vec(c, "min", &b.min);
            let max = need_vec(c, "max", &b.max);
            c.box_corners(&format!("boundaries[{i}]"), &min, &max, d);
            BoundaryGeometry::Box { min, max }
        }
        BoundaryKind::Sphere => {
            let center = need_vec(c, "center", &b.center);
            let radius = match b.radius {
                Some(r) => c.positive(&k("radius"), r),
                None => {
                    c.err(
                        &k("radius"),
                        "missing key: type = \"sphere\" needs `radius`",
                    );
                    1.0
                }
            };
            BoundaryGeometry::Sphere { center, radius }
        }
    };
    let velocity = if b.kind == BoundaryKind::Walls {
        None
    } else {
        Some(match &b.velocity {
            Some(v) => c.vector(&k("velocity"), v, d),
            None => vec![0.0; d],
        })
    };
    BoundaryDef {
        geometry,
        contact: b.contact.unwrap_or(ContactKind::Slip),
        friction: c.non_negative(&k("friction"), b.friction.unwrap_or(0.0)),
        velocity,
    }
}
