//! `[[bodies]]`: shapes filled with particles of one material, their sampling and initial
//! velocity field. The keys `phase`, `initial_phi_eff`, `concentration`, `geostatic` and `k0`
//! belong to the explicit solver (`super::explicit`), which resolves all but the first.

use super::materials::{MaterialDef, MaterialNames};
use super::Checker;
use mpm_core::sampling::{polygon_defect, PolygonDefect, Shape};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Body shape names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeKind {
    /// Axis-aligned box.
    Box,
    /// Sphere (disk in 2D).
    Sphere,
    /// Cylinder (a rectangle in 2D).
    Cylinder,
    /// Closed triangle mesh from an OBJ file (3D only).
    Mesh,
    /// Simple polygon (2D only).
    Polygon,
}

/// Sampling names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SamplingKind {
    /// Regular lattice, optionally jittered.
    Lattice,
    /// Poisson-disk sampling.
    Poisson,
}

/// A number or a list of numbers (mesh scale, angular velocity, rotation).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum NumberOrList {
    /// One number.
    Number(f64),
    /// A list of numbers.
    List(Vec<f64>),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawBody {
    name: Option<String>,
    material: String,
    phase: Option<u32>,
    shape: ShapeKind,
    min: Option<Vec<f64>>,
    max: Option<Vec<f64>>,
    center: Option<Vec<f64>>,
    radius: Option<f64>,
    axis: Option<Vec<f64>>,
    half_length: Option<f64>,
    file: Option<String>,
    scale: Option<NumberOrList>,
    rotation: Option<NumberOrList>,
    vertices: Option<Vec<Vec<f64>>>,
    translation: Option<Vec<f64>>,
    sampling: Option<SamplingKind>,
    per_axis: Option<u32>,
    jitter: Option<f64>,
    seed: Option<u64>,
    poisson_radius: Option<f64>,
    velocity: Option<Vec<f64>>,
    velocity_gradient: Option<Vec<Vec<f64>>>,
    angular_velocity: Option<NumberOrList>,
    about: Option<Vec<f64>>,
    /// Read by the explicit solver's module.
    pub(crate) initial_phi_eff: Option<f64>,
    /// Read by the explicit solver's module.
    pub(crate) concentration: Option<f64>,
    /// Read by the explicit solver's module.
    pub(crate) geostatic: Option<bool>,
    /// Read by the explicit solver's module.
    pub(crate) k0: Option<f64>,
}

/// One `[[bodies]]` entry.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BodyDef {
    /// Name (for messages).
    pub name: String,
    /// Material name.
    pub material: String,
    /// Index of the material in `Scene::materials`.
    #[serde(skip)]
    pub material_index: usize,
    /// Phase (grid) the body lives on.
    pub phase: u32,
    /// Shape.
    #[serde(flatten)]
    pub shape: ShapeDef,
    /// Sampling.
    #[serde(flatten)]
    pub sampling: SamplingDef,
    /// Constant part of the initial velocity v₀ (m/s).
    pub velocity: Vec<f64>,
    /// Affine initial velocity gradient A (1/s): `v = v₀ + A (x − about)`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub velocity_gradient: Option<Vec<Vec<f64>>>,
    /// Rigid rotation ω (rad/s; one number in 2D, a vector in 3D): `v = v₀ + ω × (x − about)`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub angular_velocity: Option<NumberOrList>,
    /// Reference point of the affine or rotational field (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub about: Option<Vec<f64>>,
    /// Initial effective volume fraction φ_eff (dimensionless; with `[porous]` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub initial_phi_eff: Option<f64>,
    /// Initial concentration α of the second mixing fluid, or initial dissolution progress of
    /// the dissolving solid (dimensionless; with `[mixing]` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub concentration: Option<f64>,
    /// Whether the body starts in its geostatic stress state (explicit solver only).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub geostatic: bool,
    /// Earth-pressure coefficient K₀ = σ_h/σ_v of a geostatic solid body (dimensionless);
    /// `None` for ν/(1 − ν) or a fluid.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k0: Option<f64>,
}

/// A body shape with its parameters.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "shape", rename_all = "snake_case")]
pub enum ShapeDef {
    /// Box: axis-aligned, or in 2D turned by `rotation` about its centre.
    Box {
        /// Lower corner (m), before the rotation.
        min: Vec<f64>,
        /// Upper corner (m), before the rotation.
        max: Vec<f64>,
        /// Counter-clockwise rotation about the box centre (degrees; 2D only).
        #[serde(skip_serializing_if = "Option::is_none")]
        rotation: Option<f64>,
    },
    /// Sphere (disk in 2D).
    Sphere {
        /// Centre (m).
        center: Vec<f64>,
        /// Radius (m).
        radius: f64,
    },
    /// Cylinder.
    Cylinder {
        /// Centre (m).
        center: Vec<f64>,
        /// Axis direction.
        axis: Vec<f64>,
        /// Radius (m).
        radius: f64,
        /// Half of the length (m).
        half_length: f64,
    },
    /// OBJ triangle mesh: `x = R (scale ⊙ x_obj) + translation`.
    Mesh {
        /// OBJ file as written in the scene (relative to the scene file).
        file: String,
        /// Per-axis scale factors.
        scale: Vec<f64>,
        /// Euler angles about x, then y, then z (degrees).
        rotation: Vec<f64>,
        /// Translation (m).
        translation: Vec<f64>,
        /// Resolved path of the OBJ file.
        #[serde(skip)]
        path: PathBuf,
    },
    /// Simple polygon (2D): vertices `[x, y]` (m) in order, either orientation.
    Polygon {
        /// Vertices (m).
        vertices: Vec<[f64; 2]>,
    },
}

/// A sampling with its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "sampling", rename_all = "snake_case")]
pub enum SamplingDef {
    /// Regular lattice.
    Lattice {
        /// Particles per cell per axis.
        per_axis: u32,
        /// Jitter as a fraction of the particle spacing, in [0, 0.5).
        jitter: f64,
        /// Seed of the jitter.
        seed: u64,
    },
    /// Poisson-disk sampling.
    Poisson {
        /// Minimum distance between particles (m).
        poisson_radius: f64,
        /// Seed.
        seed: u64,
    },
}

/// Largest number of phases (grids) a scene may have.
pub const MAX_PHASES: u32 = 16;

/// Number of phases of `bodies`: one more than the largest phase.
pub(crate) fn phase_count(bodies: &[BodyDef]) -> u32 {
    bodies
        .iter()
        .map(|b| b.phase)
        .max()
        .map_or(1, |k| k.saturating_add(1))
}

/// Most `[[bodies]]` entries a scene may have (many bodies are better sampled from one mesh
/// or polygon file); a bound on what a scene can make `check` allocate per body.
pub const MAX_BODIES: usize = 100_000;

/// Resolves `[[bodies]]`: at least one and at most [`MAX_BODIES`] bodies, with distinct names.
pub(super) fn resolve_bodies(
    c: &mut Checker<'_>,
    raw: &[RawBody],
    d: usize,
    materials: &[MaterialDef],
    base: &Path,
) -> Vec<BodyDef> {
    if raw.len() > MAX_BODIES {
        c.err(
            "bodies",
            format!("{} [[bodies]] entries; at most {MAX_BODIES}", raw.len()),
        );
        return Vec::new();
    }
    let names = MaterialNames::new(materials);
    let bodies: Vec<BodyDef> = raw
        .iter()
        .enumerate()
        .map(|(i, b)| resolve_body(c, i, b, d, &names, base))
        .collect();
    if raw.is_empty() {
        c.err("bodies", "a scene needs at least one [[bodies]] entry");
    }
    let mut seen = std::collections::HashSet::new();
    for (i, b) in bodies.iter().enumerate() {
        if !seen.insert(b.name.as_str()) {
            c.err(
                &format!("bodies[{i}].name"),
                format!("duplicate body name \"{}\"", b.name),
            );
        }
    }
    bodies
}

fn resolve_body(
    c: &mut Checker<'_>,
    i: usize,
    b: &RawBody,
    d: usize,
    materials: &MaterialNames<'_>,
    base: &Path,
) -> BodyDef {
    let k = |name: &str| format!("bodies[{i}].{name}");
    let name = b.name.clone().unwrap_or_else(|| format!("body{i}"));
    let material_index = materials.find(c, &k("material"), &b.material).unwrap_or(0);
    let phase = b.phase.unwrap_or(0);
    if phase >= MAX_PHASES {
        c.err(
            &k("phase"),
            format!("must be below {MAX_PHASES} (got {phase})"),
        );
    }
    let has = |key: &str| -> bool {
        match key {
            "min" => b.min.is_some(),
            "max" => b.max.is_some(),
            "center" => b.center.is_some(),
            "radius" => b.radius.is_some(),
            "axis" => b.axis.is_some(),
            "half_length" => b.half_length.is_some(),
            "file" => b.file.is_some(),
            "scale" => b.scale.is_some(),
            "rotation" => b.rotation.is_some(),
            "translation" => b.translation.is_some(),
            "vertices" => b.vertices.is_some(),
            _ => false,
        }
    };
    let all = [
        "min",
        "max",
        "center",
        "radius",
        "axis",
        "half_length",
        "file",
        "scale",
        "rotation",
        "translation",
        "vertices",
    ];
    let used: &[&str] = match b.shape {
        ShapeKind::Box => &["min", "max", "rotation"],
        ShapeKind::Sphere => &["center", "radius"],
        ShapeKind::Cylinder => &["center", "axis", "radius", "half_length"],
        ShapeKind::Mesh => &["file", "scale", "rotation", "translation"],
        ShapeKind::Polygon => &["vertices"],
    };
    let shape_name = super::serde_plain(&b.shape);
    for key in all {
        if !used.contains(&key) {
            c.not_applicable(&k(key), has(key), &format!("to shape = \"{shape_name}\""));
        }
    }
    let what = format!("shape = \"{shape_name}\"");
    let need_vec = |c: &mut Checker<'_>, key: &str, v: &Option<Vec<f64>>| {
        c.required_vector(&k(key), v.as_deref(), d, &what)
    };
    let need_num = |c: &mut Checker<'_>, key: &str, v: Option<f64>| -> f64 {
        match v {
            Some(v) => c.positive(&k(key), v),
            None => {
                c.err(&k(key), format!("missing key: {what} needs `{key}`"));
                1.0
            }
        }
    };
    let shape = match b.shape {
        ShapeKind::Box => {
            let min = need_vec(c, "min", &b.min);
            let max = need_vec(c, "max", &b.max);
            c.box_corners(&format!("bodies[{i}]"), &min, &max, d);
            let rotation = b.rotation.as_ref().map(|r| match (d, r) {
                (2, NumberOrList::Number(deg)) => c.num(
                    &k("rotation"),
                    *deg,
                    |_| true,
                    "must be a finite angle (degrees)",
                ),
                _ => {
                    c.err(
                        &k("rotation"),
                        if d == 2 {
                            "a box's rotation is one angle (degrees, counter-clockwise)"
                        } else {
                            "a box turns only in 2D; in 3D use shape = \"mesh\" with `rotation`"
                        },
                    );
                    0.0
                }
            });
            ShapeDef::Box { min, max, rotation }
        }
        ShapeKind::Polygon => ShapeDef::Polygon {
            vertices: resolve_polygon(c, &k("vertices"), b.vertices.as_deref(), d, &k("shape")),
        },
        ShapeKind::Sphere => ShapeDef::Sphere {
            center: need_vec(c, "center", &b.center),
            radius: need_num(c, "radius", b.radius),
        },
        ShapeKind::Cylinder => {
            let axis = need_vec(c, "axis", &b.axis);
            if axis.len() == d && axis.iter().all(|x| x.is_finite()) {
                let n: f64 = axis.iter().map(|x| x * x).sum::<f64>().sqrt();
                if !(n > 0.0 && n.is_finite()) {
                    c.err(&k("axis"), "must be a non-zero vector");
                }
            }
            ShapeDef::Cylinder {
                center: need_vec(c, "center", &b.center),
                axis,
                radius: need_num(c, "radius", b.radius),
                half_length: need_num(c, "half_length", b.half_length),
            }
        }
        ShapeKind::Mesh => {
            if d != 3 {
                c.err(
                    &k("shape"),
                    "shape = \"mesh\" needs dim = 3 (a mesh cannot be sampled in 2D)",
                );
            }
            let file = match &b.file {
                Some(f) if !f.trim().is_empty() => f.clone(),
                Some(_) => {
                    c.err(&k("file"), "must name an OBJ file");
                    String::new()
                }
                None => {
                    c.err(&k("file"), "missing key: shape = \"mesh\" needs `file`");
                    String::new()
                }
            };
            let scale = match &b.scale {
                None => vec![1.0; 3],
                Some(NumberOrList::Number(s)) => vec![*s; 3],
                Some(NumberOrList::List(v)) => c.vector(&k("scale"), v, 3),
            };
            if scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
                c.err(&k("scale"), "scale factors must be positive finite numbers");
            }
            let rotation = match &b.rotation {
                Some(NumberOrList::List(r)) => c.vector(&k("rotation"), r, 3),
                Some(NumberOrList::Number(_)) => {
                    c.err(
                        &k("rotation"),
                        "a mesh's rotation is three Euler angles [x, y, z] (degrees)",
                    );
                    vec![0.0; 3]
                }
                None => vec![0.0; 3],
            };
            let translation = match &b.translation {
                Some(t) => c.vector(&k("translation"), t, 3),
                None => vec![0.0; 3],
            };
            ShapeDef::Mesh {
                path: base.join(&file),
                file,
                scale,
                rotation,
                translation,
            }
        }
    };
    let sampling = match b.sampling.unwrap_or(SamplingKind::Lattice) {
        SamplingKind::Lattice => {
            c.not_applicable(
                &k("poisson_radius"),
                b.poisson_radius.is_some(),
                "to sampling = \"lattice\"",
            );
            let per_axis = b.per_axis.unwrap_or(2);
            if !(1..=8).contains(&per_axis) {
                c.err(
                    &k("per_axis"),
                    format!("must lie in 1..=8 (got {per_axis})"),
                );
            }
            SamplingDef::Lattice {
                per_axis,
                jitter: c.num(
                    &k("jitter"),
                    b.jitter.unwrap_or(0.0),
                    |j| (0.0..0.5).contains(&j),
                    "must lie in [0, 0.5)",
                ),
                seed: b.seed.unwrap_or(0),
            }
        }
        SamplingKind::Poisson => {
            for key in ["per_axis", "jitter"] {
                let present = if key == "per_axis" {
                    b.per_axis.is_some()
                } else {
                    b.jitter.is_some()
                };
                c.not_applicable(&k(key), present, "to sampling = \"poisson\"");
            }
            let r = match b.poisson_radius {
                Some(r) => c.positive(&k("poisson_radius"), r),
                None => {
                    c.err(
                        &k("poisson_radius"),
                        "missing key: sampling = \"poisson\" needs `poisson_radius` (m)",
                    );
                    1.0
                }
            };
            SamplingDef::Poisson {
                poisson_radius: r,
                seed: b.seed.unwrap_or(0),
            }
        }
    };
    let velocity = match &b.velocity {
        Some(v) => c.vector(&k("velocity"), v, d),
        None => vec![0.0; d],
    };
    if b.velocity_gradient.is_some() && b.angular_velocity.is_some() {
        c.err(
            &k("angular_velocity"),
            "give either velocity_gradient or angular_velocity, not both",
        );
    }
    let velocity_gradient = b.velocity_gradient.as_ref().map(|rows| {
        if rows.len() != d || rows.iter().any(|r| r.len() != d) {
            c.err(
                &k("velocity_gradient"),
                format!("must be a {d}×{d} matrix (a list of {d} rows of {d} numbers)"),
            );
        } else if rows.iter().flatten().any(|x| !x.is_finite()) {
            c.err(&k("velocity_gradient"), "must be finite numbers");
        }
        rows.clone()
    });
    let angular_velocity = b.angular_velocity.as_ref().map(|w| {
        match (d, w) {
            (2, NumberOrList::Number(x)) => {
                if !x.is_finite() {
                    c.err(&k("angular_velocity"), format!("must be finite (got {x})"));
                }
            }
            (3, NumberOrList::List(v)) => {
                c.vector(&k("angular_velocity"), v, 3);
            }
            _ => c.err(
                &k("angular_velocity"),
                if d == 2 {
                    "in 2D, angular_velocity is one number (rad/s)"
                } else {
                    "in 3D, angular_velocity is a vector [wx, wy, wz] (rad/s)"
                },
            ),
        }
        w.clone()
    });
    let about = if velocity_gradient.is_some() || angular_velocity.is_some() {
        Some(match &b.about {
            Some(p) => c.vector(&k("about"), p, d),
            None => shape_center(&shape, d),
        })
    } else {
        c.not_applicable(
            &k("about"),
            b.about.is_some(),
            "without velocity_gradient or angular_velocity",
        );
        None
    };
    BodyDef {
        name,
        material: b.material.clone(),
        material_index,
        phase,
        shape,
        sampling,
        velocity,
        velocity_gradient,
        angular_velocity,
        about,
        initial_phi_eff: None,
        concentration: None,
        geostatic: false,
        k0: None,
    }
}

/// The vertices of `shape = "polygon"` at `key`: a list of `[x, y]` pairs forming a simple
/// polygon of positive area ([`polygon_defect`]), in a 2D scene (`shape_key` otherwise).
fn resolve_polygon(
    c: &mut Checker<'_>,
    key: &str,
    raw: Option<&[Vec<f64>]>,
    d: usize,
    shape_key: &str,
) -> Vec<[f64; 2]> {
    if d != 2 {
        c.err(
            shape_key,
            "shape = \"polygon\" needs dim = 2 (in 3D use shape = \"mesh\")",
        );
        return Vec::new();
    }
    let Some(raw) = raw else {
        c.err(key, "missing key: shape = \"polygon\" needs `vertices`");
        return Vec::new();
    };
    let mut vertices = Vec::with_capacity(raw.len());
    for (j, v) in raw.iter().enumerate() {
        match v.as_slice() {
            &[x, y] => vertices.push([x, y]),
            _ => {
                c.err(
                    &format!("{key}[{j}]"),
                    format!("a vertex is [x, y] (m), got {} numbers", v.len()),
                );
                return Vec::new();
            }
        }
    }
    match polygon_defect(&vertices) {
        Some(PolygonDefect::NonFinite(j)) => {
            c.err(&format!("{key}[{j}]"), "must be finite numbers");
        }
        Some(e) => c.err(key, e.to_string()),
        None => {}
    }
    vertices
}

/// Centre of a shape's bounding box (mesh: its translation).
fn shape_center(s: &ShapeDef, d: usize) -> Vec<f64> {
    match s {
        ShapeDef::Box { min, max, .. } => min.iter().zip(max).map(|(a, b)| 0.5 * (a + b)).collect(),
        ShapeDef::Polygon { vertices } => {
            let polygon = Shape::<2>::Polygon {
                vertices: vertices.clone(),
            };
            let (lo, hi) = polygon.bounds();
            ((lo + hi) * 0.5).as_slice().to_vec()
        }
        ShapeDef::Sphere { center, .. } | ShapeDef::Cylinder { center, .. } => center.clone(),
        ShapeDef::Mesh { translation, .. } => {
            let mut t = translation.clone();
            t.resize(d, 0.0);
            t
        }
    }
}
