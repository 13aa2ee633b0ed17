//! Colours: the viridis map and the categorical palette, depth shading, what a frame is
//! coloured by ([`Colouring`]), and the per-particle values of the colour field (and the
//! positions) read from a snapshot.

use mpm_io::{Data, Snapshot};

/// Viridis colour map, `t` in [0, 1].
pub fn viridis(t: f64) -> [u8; 3] {
    const C: [[f64; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = t * 8.0;
    let i = (s.floor() as usize).min(7);
    let f = s - i as f64;
    std::array::from_fn(|k| (C[i][k] + f * (C[i + 1][k] - C[i][k])).round() as u8)
}

/// Categorical colours for materials.
pub const PALETTE: [[u8; 3]; 10] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
    [188, 189, 34],
    [23, 190, 207],
];

pub(super) fn shade(c: [u8; 3], f: f64) -> [u8; 3] {
    c.map(|v| (v as f64 * f).round().clamp(0.0, 255.0) as u8)
}

/// Fields whose values are fractions in [0, 1], drawn on that fixed range.
pub(super) const FRACTIONS: [&str; 2] = ["phi_eff", "concentration"];

/// Fields drawn with categorical colours and a legend.
pub(super) const CATEGORICAL: [&str; 2] = ["material", "phase"];

pub(super) fn field_f64<'a>(s: &'a Snapshot, name: &str) -> Option<(&'a [f64], &'a [usize])> {
    match &s.field(name)?.data {
        Data::F64 { values, shape } => Some((values, shape)),
        Data::U32 { .. } => None,
    }
}

/// Per-particle colour values of `field`, or an error naming the fields that exist.
pub(super) fn values_of(s: &Snapshot, field: &str) -> Result<(Vec<f64>, String), String> {
    let n = positions(s)?.len();
    if field == "speed" {
        let (v, shape) = field_f64(s, "v").ok_or("`speed` needs the field `v`")?;
        let d = shape.get(1).copied().unwrap_or(1).max(1);
        return Ok((
            v.chunks_exact(d)
                .map(|c| c.iter().map(|x| x * x).sum::<f64>().sqrt())
                .collect(),
            "m/s".into(),
        ));
    }
    let f = s.field(field).ok_or_else(|| {
        let names: Vec<&str> = s.fields.iter().map(|f| f.name.as_str()).collect();
        format!(
            "no field `{field}` in the snapshot (fields: speed, {})",
            names.join(", ")
        )
    })?;
    let unit = f.unit.clone();
    let (vals, shape): (Vec<f64>, Vec<usize>) = match &f.data {
        Data::F64 { values, shape } => (values.clone(), shape.clone()),
        Data::U32 { values, shape } => (values.iter().map(|&v| v as f64).collect(), shape.clone()),
    };
    let per = shape.iter().skip(1).product::<usize>().max(1);
    if shape.first() != Some(&n) || vals.len() != n * per {
        return Err(format!("field `{field}` has shape {shape:?}, not [{n}, …]"));
    }
    let out = vals
        .chunks_exact(per)
        .map(|c| match (field, shape.len(), per) {
            (_, 1, _) => c[0],
            ("F", 3, 4) => c[0] * c[3] - c[1] * c[2],
            ("F", 3, 9) => {
                c[0] * (c[4] * c[8] - c[5] * c[7]) - c[1] * (c[3] * c[8] - c[5] * c[6])
                    + c[2] * (c[3] * c[7] - c[4] * c[6])
            }
            _ => c.iter().map(|x| x * x).sum::<f64>().sqrt(),
        })
        .collect();
    let unit = if field == "F" {
        "1 (det F)".to_string()
    } else {
        unit
    };
    Ok((out, unit))
}

pub(super) fn positions(s: &Snapshot) -> Result<Vec<[f64; 3]>, String> {
    let (x, shape) = field_f64(s, "x").ok_or("the snapshot has no positions `x`")?;
    let d = shape.get(1).copied().unwrap_or(0);
    if !(d == 2 || d == 3) || shape.len() != 2 {
        return Err(format!("positions `x` have shape {shape:?}"));
    }
    Ok(x.chunks_exact(d)
        .map(|c| [c[0], c[1], if d == 3 { c[2] } else { 0.0 }])
        .collect())
}

/// How particles are coloured, and what the legend shows.
pub(super) struct Colouring<'a> {
    pub(super) categorical: bool,
    /// Colour range of a continuous field (its unit).
    pub(super) range: (f64, f64),
    /// Whether values lie below / above the range (`--range`).
    pub(super) clipped: (bool, bool),
    pub(super) field: &'a str,
    pub(super) unit: &'a str,
    pub(super) material_names: &'a [String],
}
