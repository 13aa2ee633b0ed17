//! Named columns: particle state and solver state as `(name, unit, shape, values)` arrays, the
//! form in which solvers hand their output fields and their checkpoint state to the outside
//! (the CLI writes each column as one HDF5 dataset) and take it back on resume.
//!
//! Layout: scalars are `[N]`, vectors `[N, D]`, matrices `[N, D, D]` row-major
//! (`[p, i, j] = M_ij`). The plastic state is three scalars `plastic_jp`, `plastic_q`,
//! `plastic_vc`. Units are SI; in 2D volumes are areas (m²).

use crate::material::{Material, PlasticState};
use crate::math::{det, Dim, DimOps, Matrix, Real, Vector};
use crate::particles::Particles;

/// The values of a column with their shape (`shape[0]` is the row count).
#[derive(Clone, Debug, PartialEq)]
pub enum ColumnData {
    /// Floating-point values, row-major.
    F64 {
        /// Values.
        values: Vec<f64>,
        /// Shape, rows first.
        shape: Vec<usize>,
    },
    /// Unsigned integers (material and phase indices).
    U32 {
        /// Values.
        values: Vec<u32>,
        /// Shape, rows first.
        shape: Vec<usize>,
    },
}

impl ColumnData {
    /// Shape `[N, …]` of the array.
    pub fn shape(&self) -> &[usize] {
        match self {
            ColumnData::F64 { shape, .. } | ColumnData::U32 { shape, .. } => shape,
        }
    }

    /// Number of stored values (the slice length, not the number of rows).
    pub fn value_count(&self) -> usize {
        match self {
            ColumnData::F64 { values, .. } => values.len(),
            ColumnData::U32 { values, .. } => values.len(),
        }
    }
}

/// One named column.
#[derive(Clone, Debug, PartialEq)]
pub struct Column {
    /// Name, e.g. `x` or `tlmpm_reference_x`.
    pub name: String,
    /// Unit, e.g. `m/s` (`1` for dimensionless).
    pub unit: String,
    /// Values and shape.
    pub data: ColumnData,
}

impl Column {
    /// A `[N]` scalar column.
    pub fn scalars(name: &str, unit: &str, v: &[Real]) -> Self {
        Self::f64(name, unit, v.to_vec(), vec![v.len()])
    }

    /// A `[N, D]` vector column.
    pub fn vectors<const D: usize>(name: &str, unit: &str, v: &[Vector<D>]) -> Self {
        let values = v.iter().flat_map(|x| x.iter().copied()).collect();
        Self::f64(name, unit, values, vec![v.len(), D])
    }

    /// A `[N, D, D]` matrix column, row-major.
    pub fn matrices<const D: usize>(name: &str, unit: &str, m: &[Matrix<D>]) -> Self {
        let mut values = Vec::with_capacity(m.len() * D * D);
        for a in m {
            for i in 0..D {
                for j in 0..D {
                    values.push(a[(i, j)]);
                }
            }
        }
        Self::f64(name, unit, values, vec![m.len(), D, D])
    }

    /// A `[N]` column of indices.
    pub fn indices(name: &str, v: &[u32]) -> Self {
        Self {
            name: name.to_string(),
            unit: "1".to_string(),
            data: ColumnData::U32 {
                values: v.to_vec(),
                shape: vec![v.len()],
            },
        }
    }

    fn f64(name: &str, unit: &str, values: Vec<f64>, shape: Vec<usize>) -> Self {
        Self {
            name: name.to_string(),
            unit: unit.to_string(),
            data: ColumnData::F64 { values, shape },
        }
    }

    /// The first non-finite value: `(row, value)`.
    pub fn first_non_finite(&self) -> Option<(usize, f64)> {
        match &self.data {
            ColumnData::F64 { values, shape } => {
                let per = shape.iter().skip(1).product::<usize>().max(1);
                let i = values.iter().position(|v| !v.is_finite())?;
                Some((i / per, values[i]))
            }
            ColumnData::U32 { .. } => None,
        }
    }
}

/// Looks up column `name` in `columns`.
pub fn find<'a>(columns: &'a [Column], name: &str) -> Option<&'a Column> {
    columns.iter().find(|c| c.name == name)
}

/// The f64 values of column `name`, which must have exactly `shape`; `Ok(None)` when absent.
pub fn f64_values<'a>(
    columns: &'a [Column],
    name: &str,
    shape: &[usize],
) -> Result<Option<&'a [f64]>, String> {
    match find(columns, name).map(|c| &c.data) {
        None => Ok(None),
        Some(ColumnData::F64 { values, shape: sh }) if sh.as_slice() == shape => Ok(Some(values)),
        Some(ColumnData::F64 { shape: sh, .. }) => Err(format!(
            "column `{name}` has shape {sh:?}, expected {shape:?}"
        )),
        Some(ColumnData::U32 { .. }) => Err(format!("column `{name}` is not f64")),
    }
}

/// `[N, D]` values as vectors.
pub fn to_vectors<const D: usize>(v: &[f64]) -> Vec<Vector<D>> {
    v.chunks_exact(D)
        .map(Vector::<D>::from_column_slice)
        .collect()
}

/// `[N, D, D]` row-major values as matrices.
pub fn to_matrices<const D: usize>(v: &[f64]) -> Vec<Matrix<D>> {
    v.chunks_exact(D * D)
        .map(|c| Matrix::<D>::from_fn(|i, j| c[i * D + j]))
        .collect()
}

/// Unit of volume in `D` dimensions.
fn volume_unit(d: usize) -> &'static str {
    if d == 2 {
        "m^2"
    } else {
        "m^3"
    }
}

/// Names of every particle column that can be written, in the order
/// [`particle_columns`] writes them (`plastic` stands for its three scalars).
pub const PARTICLE_COLUMN_NAMES: [&str; 12] = [
    "x",
    "v",
    "mass",
    "volume0",
    "material",
    "affine",
    "F",
    "J",
    "plastic",
    "phase",
    "phi_eff",
    "concentration",
];

/// The particle column `name` (see [`PARTICLE_COLUMN_NAMES`]); empty when the particles do
/// not have that optional column or the name is not a particle column.
pub fn particle_column<const D: usize>(particles: &Particles<D>, name: &str) -> Vec<Column> {
    let ps = particles;
    match name {
        "x" => vec![Column::vectors("x", "m", &ps.x)],
        "v" => vec![Column::vectors("v", "m/s", &ps.v)],
        "mass" => vec![Column::scalars("mass", "kg", &ps.mass)],
        "volume0" => vec![Column::scalars("volume0", volume_unit(D), &ps.volume0)],
        "material" => vec![Column::indices("material", &ps.material)],
        "affine" => vec![Column::matrices("affine", "1/s", &ps.affine)],
        "F" => ps
            .def_grad
            .iter()
            .map(|f| Column::matrices("F", "1", f))
            .collect(),
        "J" => ps
            .jacobian
            .iter()
            .map(|j| Column::scalars("J", "1", j))
            .collect(),
        "plastic" => ps.plastic.as_deref().map_or_else(Vec::new, plastic_columns),
        "phase" => ps
            .phase
            .iter()
            .map(|k| Column::indices("phase", k))
            .collect(),
        "phi_eff" => ps
            .volume_fraction
            .iter()
            .map(|f| Column::scalars("phi_eff", "1", f))
            .collect(),
        "concentration" => ps
            .concentration
            .iter()
            .map(|c| Column::scalars("concentration", "1", c))
            .collect(),
        _ => Vec::new(),
    }
}

fn plastic_columns(states: &[PlasticState]) -> Vec<Column> {
    let col = |f: fn(&PlasticState) -> f64| states.iter().map(f).collect::<Vec<_>>();
    vec![
        Column::scalars("plastic_jp", "1", &col(|s| s.jp)),
        Column::scalars("plastic_q", "1", &col(|s| s.q)),
        Column::scalars("plastic_vc", "1", &col(|s| s.vc)),
    ]
}

/// Every particle column that exists, bit-exactly (the particle part of a checkpoint).
pub fn particle_columns<const D: usize>(particles: &Particles<D>) -> Vec<Column> {
    PARTICLE_COLUMN_NAMES
        .iter()
        .flat_map(|n| particle_column(particles, n))
        .collect()
}

/// Pressure (Pa) of every particle from its material law: Tait `p(J)` for fluids, the mean
/// stress `−tr(τ)/(D J)` for solids. Solvers whose pressure is a solved unknown report that
/// instead.
pub fn material_pressure<const D: usize>(
    particles: &Particles<D>,
    materials: &[Material],
) -> Vec<Real>
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

/// Rebuilds particles from `columns` (as written by [`particle_columns`]), checking names,
/// shapes, material indices against `material_count`, and that exactly the optional columns of
/// `like` are present.
pub fn particles_from_columns<const D: usize>(
    columns: &[Column],
    like: &Particles<D>,
    material_count: usize,
) -> Result<Particles<D>, String> {
    let n = match find(columns, "x").map(|c| &c.data) {
        Some(ColumnData::F64 { shape, .. }) if shape.len() == 2 && shape[1] == D => shape[0],
        _ => return Err(format!("checkpoint has no `x` field of shape [N, {D}]")),
    };
    let need = |name: &str, shape: &[usize]| -> Result<&[f64], String> {
        f64_values(columns, name, shape)
            .map_err(|e| format!("checkpoint {e}"))?
            .ok_or_else(|| format!("checkpoint has no field `{name}`"))
    };
    let vecs = |name: &str| need(name, &[n, D]).map(to_vectors::<D>);
    let mats = |name: &str| need(name, &[n, D, D]).map(to_matrices::<D>);
    let scal = |name: &str| need(name, &[n]).map(<[f64]>::to_vec);
    let indices = |name: &str| match find(columns, name).map(|c| &c.data) {
        Some(ColumnData::U32 { values, shape }) if shape.as_slice() == [n] => Ok(values.clone()),
        _ => Err(format!(
            "checkpoint has no `{name}` field of shape [{n}] (u32)"
        )),
    };
    let x = vecs("x")?;
    let v = vecs("v")?;
    let mass = scal("mass")?;
    let volume0 = scal("volume0")?;
    let material = indices("material")?;
    if let Some(m) = material.iter().find(|&&m| m as usize >= material_count) {
        return Err(format!(
            "checkpoint refers to material {m}, but the scene defines {material_count}"
        ));
    }
    let affine = mats("affine")?;
    let cols = like.columns();
    let check = |name: &str, needed: bool| -> Result<bool, String> {
        match (needed, find(columns, name).is_some()) {
            (true, false) => Err(format!(
                "the scene needs column `{name}`, which the checkpoint lacks"
            )),
            (false, true) => Err(format!(
                "the checkpoint has column `{name}`, which this scene's particles do not have"
            )),
            _ => Ok(needed),
        }
    };
    let def_grad = check("F", cols.deformation_gradient)?
        .then(|| mats("F"))
        .transpose()?;
    let jacobian = check("J", cols.jacobian)?.then(|| scal("J")).transpose()?;
    let plastic = if check("plastic_jp", cols.plastic)? {
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
    let phase = check("phase", cols.phase)?
        .then(|| indices("phase"))
        .transpose()?;
    let volume_fraction = check("phi_eff", cols.volume_fraction)?
        .then(|| scal("phi_eff"))
        .transpose()?;
    let concentration = check("concentration", cols.concentration)?
        .then(|| scal("concentration"))
        .transpose()?;
    Ok(Particles {
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
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::particles::{Columns, ParticleExtra, ParticleInit};

    fn sample() -> Particles<2> {
        let cols = Columns {
            deformation_gradient: true,
            jacobian: true,
            plastic: true,
            phase: true,
            volume_fraction: true,
            concentration: true,
        };
        let mut ps = Particles::<2>::new(cols);
        for k in 0..5 {
            let r = k as Real;
            ps.push_with(
                ParticleInit {
                    x: Vector::<2>::new(0.1 * r, 0.3 + r),
                    v: Vector::<2>::new(-r, 1.0 / (1.0 + r)),
                    mass: 1.0 + r,
                    volume0: 0.5 + r,
                    material: (k % 2) as u32,
                    affine: Matrix::<2>::zeros(),
                },
                ParticleExtra {
                    phase: (k % 2) as u32,
                    volume_fraction: 0.1 * r,
                    concentration: 0.2 * r,
                },
            );
        }
        ps.affine[2] = Matrix::<2>::new(1.0, 2.0, 3.0, 4.0);
        ps.def_grad.as_mut().unwrap()[3] = Matrix::<2>::new(1.5, 0.25, -0.5, 0.75);
        ps.plastic.as_mut().unwrap()[4].q = 0.125;
        ps
    }

    #[test]
    fn a_selection_keeps_every_column_of_the_chosen_particles() {
        let ps = sample();
        let index = [4, 1, 3];
        let sel = ps.select(&index);
        assert_eq!(sel.len(), 3);
        assert_eq!(sel.columns(), ps.columns());
        // Mass is conserved over the chosen particles, and each column holds their values.
        let chosen: Real = index.iter().map(|&p| ps.mass[p]).sum();
        assert_eq!(sel.mass.iter().sum::<Real>(), chosen);
        for (k, &p) in index.iter().enumerate() {
            assert_eq!(sel.x[k], ps.x[p]);
            assert_eq!(sel.def_grad_of(k), ps.def_grad_of(p));
            assert_eq!(sel.plastic_of(k), ps.plastic_of(p));
            assert_eq!(sel.concentration_of(k), ps.concentration_of(p));
        }
        // Selecting everything in order gives the same particles back.
        assert_eq!(ps.select(&[0, 1, 2, 3, 4]), ps);
    }

    #[test]
    fn particles_round_trip_bitwise_through_columns() {
        let ps = sample();
        let cols = particle_columns(&ps);
        // x, v, mass, volume0, material, affine, F, J, 3 plastic, phase, phi_eff, concentration
        assert_eq!(cols.len(), 14);
        let back = particles_from_columns(&cols, &ps, 2).unwrap();
        assert_eq!(back, ps);
        // Row-major matrices: [p, i, j] = M_ij.
        let f = f64_values(&cols, "F", &[5, 2, 2]).unwrap().unwrap();
        assert_eq!(&f[12..16], &[1.5, 0.25, -0.5, 0.75]);
    }

    #[test]
    fn restore_rejects_mismatched_columns_and_materials() {
        let ps = sample();
        let cols = particle_columns(&ps);
        let e = particles_from_columns(&cols, &ps, 1).unwrap_err();
        assert!(e.contains("material 1"), "{e}");
        let fewer = Particles::<2>::new(Columns::default());
        let e = particles_from_columns(&cols, &fewer, 2).unwrap_err();
        assert!(e.contains("`F`"), "{e}");
        let without_j: Vec<Column> = cols.iter().filter(|c| c.name != "J").cloned().collect();
        let e = particles_from_columns(&without_j, &ps, 2).unwrap_err();
        assert!(e.contains("needs column `J`"), "{e}");
    }

    #[test]
    fn first_non_finite_names_the_row() {
        let mut v = vec![Vector::<3>::zeros(); 4];
        v[2][1] = Real::NAN;
        let c = Column::vectors("v", "m/s", &v);
        let (row, value) = c.first_non_finite().unwrap();
        assert_eq!(row, 2);
        assert!(value.is_nan());
        assert_eq!(
            Column::scalars("m", "kg", &[1.0, 2.0]).first_non_finite(),
            None
        );
    }
}
