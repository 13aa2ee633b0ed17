//! Particle columns as named `mpm-io` fields (snapshots and checkpoints) and back.
//!
//! Layout: vectors are `[N, D]`, matrices `[N, D, D]` row-major (`[p, i, j] = M_ij`), scalars
//! `[N]`. The plastic state is written as three scalars `plastic_jp`, `plastic_q`, `plastic_vc`.

use mpm_core::material::PlasticState;
use mpm_core::math::det;
use mpm_core::{Dim, DimOps, Material, Matrix, Particles, Real, Vector};
use mpm_io::{Data, Field, Snapshot};

/// Unit system written to every file.
pub const UNITS: &str = "SI (m, s, kg, Pa); in 2D volumes are areas (m^2)";

fn f64_field(name: &str, unit: &str, values: Vec<f64>, shape: Vec<usize>) -> Field {
    Field {
        name: name.to_string(),
        unit: unit.to_string(),
        data: Data::F64 { values, shape },
    }
}

/// A `[N, D]` vector field.
pub fn vectors<const D: usize>(name: &str, unit: &str, v: &[Vector<D>]) -> Field {
    let values = v.iter().flat_map(|x| x.iter().copied()).collect();
    f64_field(name, unit, values, vec![v.len(), D])
}

/// A `[N, D, D]` matrix field, row-major.
pub fn matrices<const D: usize>(name: &str, unit: &str, m: &[Matrix<D>]) -> Field {
    let mut values = Vec::with_capacity(m.len() * D * D);
    for a in m {
        for i in 0..D {
            for j in 0..D {
                values.push(a[(i, j)]);
            }
        }
    }
    f64_field(name, unit, values, vec![m.len(), D, D])
}

fn scalars(name: &str, unit: &str, v: &[f64]) -> Field {
    f64_field(name, unit, v.to_vec(), vec![v.len()])
}

fn plastic_fields(states: &[PlasticState]) -> [Field; 3] {
    let col = |f: fn(&PlasticState) -> f64| states.iter().map(f).collect::<Vec<_>>();
    let n = states.len();
    [
        f64_field("plastic_jp", "1", col(|s| s.jp), vec![n]),
        f64_field("plastic_q", "1", col(|s| s.q), vec![n]),
        f64_field("plastic_vc", "1", col(|s| s.vc), vec![n]),
    ]
}

/// Unit of volume in `D` dimensions.
fn volume_unit(d: usize) -> &'static str {
    if d == 2 {
        "m^2"
    } else {
        "m^3"
    }
}

/// Pressure (Pa) of every particle: Tait `p(J)` for fluids, the mean stress `−tr(τ)/(D J)` for
/// solids.
pub fn pressure<const D: usize>(particles: &Particles<D>, materials: &[Material]) -> Vec<f64>
where
    Dim<D>: DimOps<D>,
{
    (0..particles.len())
        .map(|p| match materials.get(particles.material[p] as usize) {
            Some(Material::Fluid(f)) => f.pressure(particles.jacobian_of(p)),
            Some(Material::Solid(s)) => {
                let f = particles.def_grad_of(p);
                let tau = s.kirchhoff(&f, &particles.plastic_of(p));
                -tau.trace() / (D as Real * det(&f))
            }
            None => 0.0,
        })
        .collect()
}

/// The snapshot fields named in `names` (as resolved by the scene: `x`, `v`, `mass`,
/// `volume0`, `material`, `affine`, `F`, `J`, `plastic`, `phase`, `phi_eff`, `concentration`,
/// `pressure`), in that order.
pub fn snapshot_fields<const D: usize>(
    particles: &Particles<D>,
    materials: &[Material],
    names: &[String],
) -> Vec<Field>
where
    Dim<D>: DimOps<D>,
{
    let mut out = Vec::new();
    for name in names {
        match name.as_str() {
            "x" => out.push(vectors("x", "m", &particles.x)),
            "v" => out.push(vectors("v", "m/s", &particles.v)),
            "mass" => out.push(scalars("mass", "kg", &particles.mass)),
            "volume0" => out.push(scalars("volume0", volume_unit(D), &particles.volume0)),
            "material" => out.push(Field {
                name: "material".into(),
                unit: "1".into(),
                data: Data::U32 {
                    values: particles.material.clone(),
                    shape: vec![particles.len()],
                },
            }),
            "affine" => out.push(matrices("affine", "1/s", &particles.affine)),
            "F" => {
                if let Some(f) = &particles.def_grad {
                    out.push(matrices("F", "1", f));
                }
            }
            "J" => {
                if let Some(j) = &particles.jacobian {
                    out.push(scalars("J", "1", j));
                }
            }
            "plastic" => {
                if let Some(s) = &particles.plastic {
                    out.extend(plastic_fields(s));
                }
            }
            "phase" => {
                if let Some(k) = &particles.phase {
                    out.push(Field {
                        name: "phase".into(),
                        unit: "1".into(),
                        data: Data::U32 {
                            values: k.clone(),
                            shape: vec![k.len()],
                        },
                    });
                }
            }
            "phi_eff" => {
                if let Some(f) = &particles.volume_fraction {
                    out.push(scalars("phi_eff", "1", f));
                }
            }
            "concentration" => {
                if let Some(c) = &particles.concentration {
                    out.push(scalars("concentration", "1", c));
                }
            }
            "pressure" => out.push(scalars("pressure", "Pa", &pressure(particles, materials))),
            _ => {}
        }
    }
    out
}

/// Every particle column, bit-exactly (the checkpoint payload).
pub fn checkpoint_fields<const D: usize>(particles: &Particles<D>) -> Vec<Field>
where
    Dim<D>: DimOps<D>,
{
    let mut names: Vec<String> = ["x", "v", "mass", "volume0", "material", "affine", "F", "J"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    names.extend(["plastic", "phase", "phi_eff", "concentration"].map(String::from));
    snapshot_fields(particles, &[], &names)
}

/// The first non-finite value in `fields`: `(field, particle, value)`.
pub fn first_non_finite(fields: &[Field]) -> Option<(String, usize, f64)> {
    for f in fields {
        if let Data::F64 { values, shape } = &f.data {
            let per = shape.iter().skip(1).product::<usize>().max(1);
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return Some((f.name.clone(), i / per, values[i]));
            }
        }
    }
    None
}

fn get_f64<'a>(s: &'a Snapshot, name: &str, shape: &[usize]) -> Result<&'a [f64], String> {
    let f = s
        .field(name)
        .ok_or_else(|| format!("checkpoint has no field `{name}`"))?;
    match &f.data {
        Data::F64 { values, shape: sh } if sh.as_slice() == shape => Ok(values),
        Data::F64 { shape: sh, .. } => Err(format!(
            "checkpoint field `{name}` has shape {sh:?}, expected {shape:?}"
        )),
        Data::U32 { .. } => Err(format!("checkpoint field `{name}` is not f64")),
    }
}

/// Replaces every particle column with the checkpoint's, checking names, shapes and that the
/// checkpoint has exactly the optional columns `particles` has.
pub fn restore<const D: usize>(
    particles: &mut Particles<D>,
    ckpt: &Snapshot,
    material_count: usize,
) -> Result<(), String> {
    let n = match ckpt.field("x").map(|f| &f.data) {
        Some(Data::F64 { shape, .. }) if shape.len() == 2 && shape[1] == D => shape[0],
        _ => return Err(format!("checkpoint has no `x` field of shape [N, {D}]")),
    };
    let vecs = |name: &str| -> Result<Vec<Vector<D>>, String> {
        let v = get_f64(ckpt, name, &[n, D])?;
        Ok(v.chunks_exact(D)
            .map(Vector::<D>::from_column_slice)
            .collect())
    };
    let mats = |name: &str| -> Result<Vec<Matrix<D>>, String> {
        let v = get_f64(ckpt, name, &[n, D, D])?;
        Ok(v.chunks_exact(D * D)
            .map(|c| Matrix::<D>::from_fn(|i, j| c[i * D + j]))
            .collect())
    };
    let scal = |name: &str| -> Result<Vec<f64>, String> { Ok(get_f64(ckpt, name, &[n])?.to_vec()) };
    let x = vecs("x")?;
    let v = vecs("v")?;
    let mass = scal("mass")?;
    let volume0 = scal("volume0")?;
    let material = match ckpt.field("material").map(|f| &f.data) {
        Some(Data::U32 { values, shape }) if shape.as_slice() == [n] => values.clone(),
        _ => {
            return Err(format!(
                "checkpoint has no `material` field of shape [{n}] (u32)"
            ))
        }
    };
    if let Some(m) = material.iter().find(|&&m| m as usize >= material_count) {
        return Err(format!(
            "checkpoint refers to material {m}, but the scene defines {material_count}"
        ));
    }
    let affine = mats("affine")?;
    let cols = particles.columns();
    let has = |name: &str| ckpt.field(name).is_some();
    let check = |name: &str, needed: bool| -> Result<(), String> {
        match (needed, has(name)) {
            (true, false) => Err(format!(
                "the scene needs column `{name}`, which the checkpoint lacks"
            )),
            (false, true) => Err(format!(
                "the checkpoint has column `{name}`, which this scene's particles do not have"
            )),
            _ => Ok(()),
        }
    };
    check("F", cols.deformation_gradient)?;
    check("J", cols.jacobian)?;
    check("plastic_jp", cols.plastic)?;
    check("phase", cols.phase)?;
    check("phi_eff", cols.volume_fraction)?;
    check("concentration", cols.concentration)?;
    let phase = if cols.phase {
        match ckpt.field("phase").map(|f| &f.data) {
            Some(Data::U32 { values, shape }) if shape.as_slice() == [n] => Some(values.clone()),
            _ => {
                return Err(format!(
                    "checkpoint has no `phase` field of shape [{n}] (u32)"
                ))
            }
        }
    } else {
        None
    };
    let volume_fraction = cols.volume_fraction.then(|| scal("phi_eff")).transpose()?;
    let concentration = cols
        .concentration
        .then(|| scal("concentration"))
        .transpose()?;
    let def_grad = if cols.deformation_gradient {
        Some(mats("F")?)
    } else {
        None
    };
    let jacobian = if cols.jacobian {
        Some(scal("J")?)
    } else {
        None
    };
    let plastic = if cols.plastic {
        let (jp, q, vc) = (scal("plastic_jp")?, scal("plastic_q")?, scal("plastic_vc")?);
        Some(
            (0..n)
                .map(|p| PlasticState {
                    jp: jp[p],
                    q: q[p],
                    vc: vc[p],
                })
                .collect(),
        )
    } else {
        None
    };
    *particles = Particles {
        x,
        v,
        mass,
        volume0,
        material,
        affine,
        def_grad,
        jacobian,
        plastic,
        phase,
        volume_fraction,
        concentration,
    };
    Ok(())
}
