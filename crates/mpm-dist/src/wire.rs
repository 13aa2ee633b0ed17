//! Byte encodings of what ranks send each other: particles with their ids (every column,
//! bit for bit, so a copy continues exactly as the original would), and the outcome of a step
//! attempt. Values are little-endian; particles are packed column by column straight from the
//! particle arrays.

use mpm_core::material::PlasticState;
use mpm_core::{Columns, Location, Matrix, Particles, Real, Stage, Vector, Violation};

/// The optional columns as one byte.
fn column_flags(c: Columns) -> u8 {
    [
        c.deformation_gradient,
        c.jacobian,
        c.plastic,
        c.phase,
        c.volume_fraction,
        c.concentration,
    ]
    .iter()
    .enumerate()
    .map(|(k, &on)| u8::from(on) << k)
    .sum()
}

/// Appends the particles `idx` of `ps`, with global ids `ids`, to `out`.
pub fn encode_particles<const D: usize>(
    ps: &Particles<D>,
    idx: &[usize],
    ids: &[u64],
    out: &mut Vec<u8>,
) {
    debug_assert_eq!(idx.len(), ids.len());
    put_u64(out, idx.len() as u64);
    out.push(column_flags(ps.columns()));
    for id in ids {
        put_u64(out, *id);
    }
    put_reals(out, idx, |p| ps.x[p].iter().copied());
    put_reals(out, idx, |p| ps.v[p].iter().copied());
    put_reals(out, idx, |p| [ps.mass[p]]);
    put_reals(out, idx, |p| [ps.volume0[p]]);
    put_indices(out, idx, &ps.material);
    put_reals(out, idx, |p| ps.affine[p].iter().copied());
    if let Some(f) = &ps.def_grad {
        put_reals(out, idx, |p| f[p].iter().copied());
    }
    if let Some(j) = &ps.jacobian {
        put_reals(out, idx, |p| [j[p]]);
    }
    if let Some(s) = &ps.plastic {
        put_reals(out, idx, |p| [s[p].jp, s[p].q, s[p].vc]);
    }
    if let Some(k) = &ps.phase {
        put_indices(out, idx, k);
    }
    for c in [&ps.volume_fraction, &ps.concentration]
        .into_iter()
        .flatten()
    {
        put_reals(out, idx, |p| [c[p]]);
    }
}

/// Appends the values `values(p)` of every particle `p` of `idx`.
fn put_reals<I: IntoIterator<Item = Real>>(
    out: &mut Vec<u8>,
    idx: &[usize],
    values: impl Fn(usize) -> I,
) {
    for &p in idx {
        for v in values(p) {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
}

/// Appends `column[p]` for every particle `p` of `idx`.
fn put_indices(out: &mut Vec<u8>, idx: &[usize], column: &[u32]) {
    for &p in idx {
        out.extend_from_slice(&column[p].to_le_bytes());
    }
}

/// Reads particles written by [`encode_particles`] from `bytes` (empty bytes: none); they
/// must have the columns of `like` and materials below `materials`.
pub fn decode_particles<const D: usize>(
    bytes: &[u8],
    like: &Particles<D>,
    materials: usize,
) -> Result<(Particles<D>, Vec<u64>), String> {
    let columns = like.columns();
    if bytes.is_empty() {
        return Ok((Particles::new(columns), Vec::new()));
    }
    let mut r = Reader { bytes, at: 0 };
    let n = r.u64()? as usize;
    if r.u8()? != column_flags(columns) {
        return Err("particles with other columns than this rank's".into());
    }
    let ids = r.words(n)?.map(u64::from_le_bytes).collect();
    let reals = |r: &mut Reader<'_>, per: usize| -> Result<Vec<Real>, String> {
        let count = n.checked_mul(per).ok_or("too many particles")?;
        Ok(r.words(count)?.map(Real::from_le_bytes).collect())
    };
    let vectors = |r: &mut Reader<'_>| -> Result<Vec<Vector<D>>, String> {
        Ok(reals(r, D)?
            .chunks_exact(D)
            .map(Vector::<D>::from_column_slice)
            .collect())
    };
    let matrices = |r: &mut Reader<'_>| -> Result<Vec<Matrix<D>>, String> {
        Ok(reals(r, D * D)?
            .chunks_exact(D * D)
            .map(Matrix::<D>::from_column_slice)
            .collect())
    };
    let indices = |r: &mut Reader<'_>| -> Result<Vec<u32>, String> {
        let raw = r.take(n.checked_mul(4).ok_or("too many particles")?)?;
        Ok(raw
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect())
    };
    let x = vectors(&mut r)?;
    let v = vectors(&mut r)?;
    let mass = reals(&mut r, 1)?;
    let volume0 = reals(&mut r, 1)?;
    let material = indices(&mut r)?;
    if let Some(m) = material.iter().find(|&&m| m as usize >= materials) {
        return Err(format!("material {m} of {materials}"));
    }
    let affine = matrices(&mut r)?;
    let def_grad = columns
        .deformation_gradient
        .then(|| matrices(&mut r))
        .transpose()?;
    let jacobian = columns.jacobian.then(|| reals(&mut r, 1)).transpose()?;
    let plastic = columns
        .plastic
        .then(|| {
            reals(&mut r, 3).map(|s| {
                s.chunks_exact(3)
                    .map(|s| PlasticState {
                        jp: s[0],
                        q: s[1],
                        vc: s[2],
                    })
                    .collect()
            })
        })
        .transpose()?;
    let phase = columns.phase.then(|| indices(&mut r)).transpose()?;
    let volume_fraction = columns
        .volume_fraction
        .then(|| reals(&mut r, 1))
        .transpose()?;
    let concentration = columns
        .concentration
        .then(|| reals(&mut r, 1))
        .transpose()?;
    if r.at != bytes.len() {
        return Err("message longer than its particles".into());
    }
    let ps = Particles {
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
    Ok((ps, ids))
}

/// A failed guard check as ranks exchange it: the stage by name, where (a particle by its
/// global id), what and the value.
#[derive(Clone, Debug, PartialEq)]
pub struct WireFailure {
    /// The stage's name.
    pub stage: String,
    /// Where, with particles named by global id.
    pub location: Location,
    /// What the check found.
    pub violation: Violation,
    /// The offending value.
    pub value: f64,
}

/// The quantities a [`Violation::NonFinite`] can name, so that a rank can rebuild one it
/// received; others come back as `value`.
const NON_FINITE: [&str; 10] = [
    "velocity",
    "position",
    "deformation",
    "deformation gradient",
    "elastic deformation gradient",
    "grid velocity",
    "node velocity",
    "signal speed",
    "energy density",
    "incremental potential",
];

impl WireFailure {
    /// Appends the encoding to `out`.
    pub fn encode(&self, out: &mut Vec<u8>) {
        put_str(out, &self.stage);
        let (kind, index) = match self.location {
            Location::Node(i) => (0u8, i as u64),
            Location::Particle(p) => (1, p as u64),
            Location::Global => (2, 0),
        };
        out.push(kind);
        put_u64(out, index);
        match self.violation {
            Violation::NonFinite(q) => {
                out.push(0);
                put_str(out, q);
            }
            Violation::InvertedElement => out.push(1),
            Violation::LeftDomain => out.push(2),
            Violation::CflExceeded => out.push(3),
            Violation::TimeStepTooSmall => out.push(4),
        }
        put_u64(out, self.value.to_bits());
    }

    /// Reads one failure written by [`WireFailure::encode`].
    pub fn decode(bytes: &[u8]) -> Result<Self, String> {
        let mut r = Reader { bytes, at: 0 };
        let stage = r.str()?;
        let kind = r.u8()?;
        let index = r.u64()? as usize;
        let location = match kind {
            0 => Location::Node(index),
            1 => Location::Particle(index),
            _ => Location::Global,
        };
        let violation = match r.u8()? {
            0 => {
                let q = r.str()?;
                Violation::NonFinite(NON_FINITE.iter().find(|&&k| k == q).unwrap_or(&"value"))
            }
            1 => Violation::InvertedElement,
            2 => Violation::LeftDomain,
            3 => Violation::CflExceeded,
            _ => Violation::TimeStepTooSmall,
        };
        let value = f64::from_bits(r.u64()?);
        Ok(Self {
            stage,
            location,
            violation,
            value,
        })
    }

    /// The order in which a serial step would meet the failure: by stage (`stages` in step
    /// order), then nodes before particles, then by index.
    pub fn key(&self, stages: &[Stage]) -> (usize, u8, usize) {
        let stage = stages
            .iter()
            .position(|s| s.name() == self.stage)
            .unwrap_or(stages.len());
        match self.location {
            Location::Node(i) => (stage, 0, i),
            Location::Particle(p) => (stage, 1, p),
            Location::Global => (stage, 2, 0),
        }
    }
}

fn put_u64(out: &mut Vec<u8>, v: u64) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    put_u64(out, s.len() as u64);
    out.extend_from_slice(s.as_bytes());
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| "message shorter than its header says".to_string())?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }

    fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }

    /// The next `n` 8-byte words.
    fn words(&mut self, n: usize) -> Result<impl Iterator<Item = [u8; 8]> + '_, String> {
        let raw = self.take(n.checked_mul(8).ok_or("message too long")?)?;
        Ok(raw.chunks_exact(8).map(|c| c.try_into().expect("8 bytes")))
    }

    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }

    fn str(&mut self) -> Result<String, String> {
        let n = self.u64()? as usize;
        String::from_utf8(self.take(n)?.to_vec()).map_err(|e| e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mpm_core::ParticleInit;

    #[test]
    fn particles_and_failures_round_trip_bitwise() {
        let mut ps = Particles::<2>::new(Columns {
            deformation_gradient: true,
            jacobian: true,
            plastic: true,
            phase: true,
            volume_fraction: true,
            concentration: true,
        });
        for k in 0..4 {
            ps.push(ParticleInit {
                x: Vector::<2>::new(0.1 * k as f64 + 1e-17, 1.0 / 3.0),
                v: Vector::<2>::new(-0.0, f64::MIN_POSITIVE),
                mass: 1.0 + k as f64,
                volume0: 0.5,
                material: k % 2,
                affine: Matrix::<2>::identity() * (k as f64 / 7.0),
            });
        }
        if let Some(s) = &mut ps.plastic {
            s[2].q = 0.25;
        }
        let mut bytes = Vec::new();
        encode_particles(&ps, &[0, 1, 2, 3], &[9, 3, 7, 1], &mut bytes);
        let (back, ids) = decode_particles(&bytes, &ps, 2).unwrap();
        assert_eq!(ids, vec![9, 3, 7, 1]);
        assert!(back.v[0].x.is_sign_negative());
        assert_eq!(back, ps);
        let mut two = Vec::new();
        encode_particles(&ps, &[2, 0], &[7, 9], &mut two);
        assert_eq!(
            decode_particles(&two, &ps, 2).unwrap().0,
            ps.select(&[2, 0])
        );
        assert!(decode_particles(&bytes[..bytes.len() - 1], &ps, 2).is_err());
        assert!(decode_particles(&bytes, &ps, 1).is_err(), "material 1 of 1");
        let other = Particles::<2>::new(Columns::default());
        assert!(decode_particles(&bytes, &other, 2).is_err());

        let f = WireFailure {
            stage: "g2p".into(),
            location: Location::Particle(41),
            violation: Violation::NonFinite("velocity"),
            value: f64::NAN,
        };
        let mut b = Vec::new();
        f.encode(&mut b);
        let g = WireFailure::decode(&b).unwrap();
        assert_eq!(
            (g.stage.as_str(), g.location),
            ("g2p", Location::Particle(41))
        );
        assert_eq!(g.violation, Violation::NonFinite("velocity"));
        assert!(g.value.is_nan());
    }
}
